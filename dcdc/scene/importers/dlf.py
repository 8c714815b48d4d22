"""DeepLagrangianFluids scene JSON (``scripts/example_scene.json`` of
isl-org/DeepLagrangianFluids) as a dcdc scene.

Their format: ``walls`` = [{path, translation, invert_normals}], ``fluids`` = [{path,
velocity, translation, start, stop, step}]. Their run_network.py samples a wall mesh's
surface with normals pointing against the face normals (``invert_normals`` flips them)
and adds a fluid mesh's volume at every frame of ``range(start, stop, step)`` (Δt = 1/50
s). Here:

* a closed wall mesh is a ``mesh`` wall: the container around the space its normals point
  into (``hollow = true`` for their outward-wound Box.obj), the solid with
  ``invert_normals``; an open wall mesh is a shell of 4r on the side its normals point away
  from the fluid;
* a fluid released at frame 0 only is a ``[[fluid]]`` of shape ``mesh``; one released at
  several frames is an ``[[emitter]]`` of shape ``mesh`` (start = start·Δt, interval =
  step·Δt, stop = stop·Δt);
* one phase ``fluid`` of 1000 kg/m³ (their scenes name no material; :func:`dcdc.model.dlf.scene_system`
  uses the same), r = 0.025 m, frame Δt = 1/50 s; the domain is the bounds of walls and
  fluid grown by 5 % (their run_network.py drops particles 5 % outside the walls' box).

Mesh paths are resolved as :func:`dcdc.model.dlf.scene_system` resolves them (their
``../datasets/models/X.obj`` is also looked for beside the JSON).
"""
from __future__ import annotations

from pathlib import Path

from ...errors import DcdcError
from ...model.dlf import FRAME_DT, PARTICLE_RADIUS, _mesh_path
from .common import Reader, domain, finish, scene_name, toml_path, unique

TOP_KEYS = {"walls", "fluids"}
WALL_KEYS = {"path", "translation", "invert_normals"}
FLUID_KEYS = {"path", "velocity", "translation", "start", "stop", "step"}
DENSITY = 1000.0
FMT = "DeepLagrangianFluids"


def is_dlf(data) -> bool:
    return isinstance(data, dict) and "walls" in data and "fluids" in data


def _mesh(rd: Reader, obj: dict, where: str, base: Path):
    from ...geometry import mesh as gm
    file = rd.string(obj, "path", where)
    if file is None:
        rd.fail(where, "needs a 'path' (the OBJ file)")
    try:
        p = _mesh_path(file, base)
    except DcdcError as e:
        rd.fail(f"{where}:", str(e))
    t = rd.vec3(obj, "translation", where, [0.0, 0.0, 0.0])
    return p, t, gm.load_placed_mesh(p, 1.0, t)


def convert(data: dict, path: Path, output: Path | None, name: str | None = None):
    """The dcdc scene (:class:`~.common.Imported`) of their scene JSON ``data``."""
    rd = Reader(path.name)
    rd.keys(data, "the scene", TOP_KEYS, "DeepLagrangianFluids scene")
    walls_in, fluids_in = rd.items(data, "walls"), rd.items(data, "fluids")
    if not walls_in or not fluids_in:
        raise DcdcError(f"{path.name}: a DeepLagrangianFluids scene needs non-empty 'walls' and "
                        "'fluids' lists")
    base = path.parent
    r = PARTICLE_RADIUS
    warnings, bounds, walls = [], [], {}
    for i, w in enumerate(walls_in):
        where = f"walls[{i}]"
        rd.keys(w, where, WALL_KEYS, "DeepLagrangianFluids wall")
        invert = rd.flag(w, "invert_normals", where, False)
        p, t, m = _mesh(rd, w, where, base)
        entry = {"shape": "mesh", "file": toml_path(p, output), "translate": t}
        if m.metadata["dcdc_closed"]:
            # their wall normals point against the face normals, into the fluid: inside an
            # outward-wound closed mesh (dcdc winds every closed mesh outwards, so a mesh
            # that was wound inwards had its fluid outside)
            entry["hollow"] = not (invert ^ bool(m.metadata["dcdc_flipped"]))
        else:
            entry["thickness"] = 4 * r
            entry["invert_normals"] = not invert  # the solid is where their normals come from
        walls[unique(scene_name(p.stem, "wall"), walls)] = entry
        bounds.append(m.bounds)
    fluids, emitters, last = [], [], 0.0
    for i, f in enumerate(fluids_in):
        where = f"fluids[{i}]"
        rd.keys(f, where, FLUID_KEYS, "DeepLagrangianFluids fluid")
        vel = rd.vec3(f, "velocity", where, [0.0, 0.0, 0.0])
        start = rd.integer(f, "start", where, 0)
        stop = rd.integer(f, "stop", where, 1)
        step = rd.integer(f, "step", where, 1)
        if start < 0:
            rd.fail(f"{where}.start", f"must be a frame >= 0 (got {start})")
        if step < 1:
            rd.fail(f"{where}.step", f"must be >= 1 (got {step})")
        p, t, m = _mesh(rd, f, where, base)
        if not m.metadata["dcdc_closed"]:
            from ...geometry import mesh as gm
            try:
                gm.require_closed(m, "a fluid body must be a closed mesh")
            except DcdcError as e:
                raise DcdcError(f"{path.name}: {where}: {e}") from None
        frames = range(start, stop, step)
        if not len(frames):
            warnings.append(f"{where} ({p.name}): released at no frame (start {start} >= stop {stop}); "
                            "left out")
            continue
        placed = {"phase": "fluid", "shape": "mesh", "file": toml_path(p, output), "translate": t}
        if list(frames) == [0]:
            fluids.append({**placed, "velocity": vel, "name": f"{where} {p.stem}"})
        else:
            emitters.append({**placed, "velocity": vel, "start": round(start * FRAME_DT, 9),
                             "stop": round(stop * FRAME_DT, 9), "interval": round(step * FRAME_DT, 9)})
            last = max(last, frames[-1] * FRAME_DT)
        bounds.append(m.bounds)
    scene = {
        "name": scene_name(name or path.stem),
        "description": f"imported from the DeepLagrangianFluids scene {path.name}",
        "dim": 3, "radius": r, "duration": max(2.0, round(last + 1.0, 6)), "frame_dt": FRAME_DT,
        "domain": domain(bounds),
        "phases": {"fluid": {"density": DENSITY}},
        "walls": walls,
    }
    if fluids:
        scene["fluid"] = fluids
    if emitters:
        scene["emitter"] = emitters
    notes = ["one phase 'fluid' of 1000 kg/m³ (the JSON names no material); walls are dcdc's "
             "solid walls, not DLF's surface samples; frames of 1/50 s"]
    return finish(scene, warnings, FMT, path, output, notes)
