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
* one phase ``fluid`` of 1000 kg/m³ (their scenes name no material; :func:`scene_system`
  uses the same), r = 0.025 m, frame Δt = 1/50 s; the domain is the bounds of walls and
  fluid grown by 5 % (their run_network.py drops particles 5 % outside the walls' box).

Mesh paths are resolved as :func:`scene_system` resolves them (their
``../datasets/models/X.obj`` is also looked for beside the JSON).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import DcdcError
from ...particles import DEFAULT_RADIUS as PARTICLE_RADIUS  # their r = 0.025 m is ours
from ...particles import FRAME_DT  # their Δt = 1/50 s is ours
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
        p = mesh_path(file, base)
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


# ------------------------------------------------------- their own wall sampling
def surface_points(mesh, radius: float = PARTICLE_RADIUS):
    """Wall particles on a mesh surface with their normals pointing inwards (−face normal),
    at their surface density 1.9 / (π r²) (run_network.py samples that many Poisson-disk
    points; we use a square grid of the same density in the plane of each triangle,
    anchored per plane so that coplanar triangles share one grid)."""
    s = float(np.sqrt(np.pi * radius ** 2 / 1.9))
    pts, nrm = [], []
    for tri, n in zip(np.asarray(mesh.triangles), np.asarray(mesh.face_normals)):
        # a tangent frame fixed by the normal alone
        a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
        u = np.cross(n, a)
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        off = float(tri[0] @ n) * n  # the plane's point nearest the origin
        uv = np.stack([(tri - off) @ u, (tri - off) @ w], axis=1)
        lo, hi = uv.min(0), uv.max(0)
        i = np.arange(np.floor(lo[0] / s) - 1, np.ceil(hi[0] / s) + 2) * s + s / 2
        j = np.arange(np.floor(lo[1] / s) - 1, np.ceil(hi[1] / s) + 2) * s + s / 2
        g = np.stack(np.meshgrid(i, j, indexing="ij"), -1).reshape(-1, 2)
        # inside the triangle (half-open on shared edges by the + s/2 grid offset)
        T = np.array([uv[1] - uv[0], uv[2] - uv[0]]).T
        bc = np.linalg.solve(T, (g - uv[0]).T).T
        inside = (bc >= 0).all(1) & (bc.sum(1) < 1)
        g = g[inside]
        pts.append(off + g[:, :1] * u + g[:, 1:] * w)
        nrm.append(np.tile(-n, (len(g), 1)))
    pts, nrm = np.concatenate(pts), np.concatenate(nrm)
    # a grid point on an edge shared by coplanar triangles is found by both: keep one
    _, keep = np.unique(np.round(np.c_[pts, nrm] / (1e-6 * s)), axis=0, return_index=True)
    keep.sort()
    return pts[keep], nrm[keep]


def _load(path: str, base: Path, translation):
    """A scene mesh; vertices split by per-face OBJ normals are merged first (their Box.obj
    and Fluid.obj are closed cubes written with one normal per face)."""
    import trimesh

    from ...geometry.shapes import load_mesh

    p = mesh_path(path, base)
    try:
        raw = trimesh.load(str(p), force="mesh")
        raw.merge_vertices(merge_tex=True, merge_norm=True)
    except Exception as e:  # trimesh raises many types for broken files
        raise DcdcError(f"cannot read mesh {p}: {e}") from None
    if raw.is_watertight:
        raw.apply_translation(np.asarray(translation, dtype=np.float64).reshape(3))
        return raw
    return load_mesh(p, translate=translation)  # patches small holes or says why not


def mesh_path(path: str, base: Path) -> Path:
    """A mesh file named by their JSON: relative to the JSON, or beside it (their
    ``../datasets/models/X.obj``)."""
    p = Path(path)
    p = p if p.is_absolute() else base / p
    if not p.exists() and (base / p.name).exists():
        p = base / p.name  # the JSON's ../datasets/models/X.obj, shipped beside it
    if not p.exists():
        raise DcdcError(f"mesh {path} of the scene not found (looked in {base})")
    return p


def scene_system(path, radius: float = PARTICLE_RADIUS, frames: int = 1,
                 dt: float = FRAME_DT):
    """Their scene JSON as a 3-D :class:`~dcdc.particles.ParticleSystem` (one phase,
    1000 kg/m³). A fluid with ``start``/``stop``/``step`` is emitted (whole) at each step of
    ``range(start, stop, step)`` below ``frames``; the domain is the walls' bounding box
    grown by 5 % of its size (their run_network.py drops particles 5 % below the box)."""
    from ...geometry.sampling import fill_region
    from ...geometry.shapes import mesh_solid
    from ...particles import ParticleSystem, Phase

    path = Path(path)
    try:
        scene = json.loads(path.read_text())
    except FileNotFoundError:
        raise DcdcError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DcdcError(f"{path}: not a JSON scene ({str(e).splitlines()[0]})") from None
    except RecursionError:
        raise DcdcError(f"{path}: arrays or objects nested too deeply to read") from None
    if not isinstance(scene, dict) or not scene.get("walls") or not scene.get("fluids"):
        raise DcdcError(f"{path}: a DeepLagrangianFluids scene needs 'walls' and 'fluids' lists")
    base = path.parent
    wx, wn = [], []
    for i, w in enumerate(scene["walls"]):
        try:
            mesh = _load(w["path"], base, w.get("translation", [0, 0, 0]))
        except (KeyError, TypeError, ValueError):
            raise DcdcError(f"{path}: walls[{i}] needs a 'path' (and optional 'translation')") from None
        p, n = surface_points(mesh, radius)
        wx.append(p)
        wn.append(-n if w.get("invert_normals") else n)
    xs, vs, births = [], [], []
    spacing = 2 * radius
    for i, f in enumerate(scene["fluids"]):
        try:
            mesh = _load(f["path"], base, f.get("translation", [0, 0, 0]))
            vel = np.asarray(f.get("velocity", [0, 0, 0]), dtype=np.float64).reshape(3)
            steps = range(int(f.get("start", 0)), int(f.get("stop", 1)), int(f.get("step", 1)))
        except (KeyError, TypeError, ValueError):
            raise DcdcError(f"{path}: fluids[{i}] needs 'path', 'velocity' (3 numbers), "
                            "'translation', and integer 'start', 'stop', 'step'") from None
        sdf = mesh_solid(mesh)
        lo, hi = mesh.bounds
        pts = fill_region(lambda q: sdf(q) < 0, lo + radius, hi - radius, spacing, lo + radius)
        for k in steps:
            if k >= max(frames, 1):
                break
            xs.append(pts)
            vs.append(np.tile(vel, (len(pts), 1)))
            births.append(np.full(len(pts), k * dt))
    if not xs:
        raise DcdcError(f"{path}: no fluid particles (empty fluid volume or no emission step)")
    wall_x = np.concatenate(wx)
    lo, hi = wall_x.min(0), wall_x.max(0)
    pad = 0.05 * (hi - lo)
    return ParticleSystem(3, radius, np.concatenate(xs), np.concatenate(vs),
                          np.zeros(sum(len(x) for x in xs), dtype=np.int32),
                          [Phase("fluid", 1000.0)], wall_x, np.concatenate(wn),
                          (0.0, -9.81, 0.0), (lo - pad, hi + pad), np.concatenate(births),
                          path.stem)
