"""Realisation: a validated scene variant (:mod:`.schema`, :mod:`.variant`) as particles. The
walls become signed distance functions (boxes, spheres, cylinders, solids of revolution,
terrain, meshes) whose union the wall particles sample; fluid blocks fill the global lattice
inside them; emitters release particles over time (:mod:`.nozzles`, mesh emitters). A scene
without ``[domain]`` gets the box around its walls and fluid (:func:`derive_domain`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from ..particles import ParticleSystem, Phase
from .lines import find_line
from .nozzles import nozzle_layer, nozzle_points


@dataclass
class _Solid:
    name: str
    sdf: object
    inside: object  # predicate: the fluid space this wall encloses (for shape = "fill")
    bounds: tuple | None = None
    mesh: object = None  # the trimesh of a mesh wall (for its checks)


def _mesh_file(field: str, file: str, base_dir: Path | None) -> Path:
    """The path of a scene's mesh file: ``asset:NAME`` is a mesh shipped with dcdc
    (dcdc/assets), a relative path is relative to the scene file."""
    p = Path(file)
    if file.startswith("asset:"):
        from importlib import resources
        p = Path(str(resources.files("dcdc").joinpath("assets", file[6:])))
    elif not p.is_absolute():
        p = (base_dir or Path.cwd()) / p
    if not p.exists():
        raise DcdcError(f"{field}.file: mesh file {p} not found")
    return p


def _placed_mesh(field: str, d: dict, base_dir: Path | None, cache: dict | None = None):
    """The mesh of a wall, fluid block or emitter of shape "mesh", scaled, rotated and
    translated; ``cache`` keeps each placed mesh of one realisation loaded once."""
    from ..geometry import mesh as gm
    p = _mesh_file(field, d["file"], base_dir)
    key = (str(p), repr(d["scale"]), repr(d["rotation_axis"]), d["rotation_degrees"], repr(d["translate"]))
    if cache is not None and key in cache:
        return cache[key]
    m = gm.load_placed_mesh(p, d["scale"], d["translate"], d["rotation_axis"], d["rotation_degrees"])
    if cache is not None:
        cache[key] = m
    return m


def _build_walls(s: dict, base_dir: Path | None, thickness: float,
                 meshes: dict | None = None) -> list[_Solid]:
    from ..geometry import shapes as sh
    dim = s["dim"]
    # mesh SDFs are exact within this distance of the surface (sampled walls, normals,
    # fill clearances, the SPH volume map), a bound of the right sign beyond
    spacing = 2 * s["radius"]
    band = thickness + 2 * spacing + max([f.get("clearance") or 0.0 for f in s["fluid"]] + [spacing])
    out = []
    for name, w in s["walls"].items():
        shape = w["shape"]
        if shape == "box":
            if w["hollow"]:
                sdf = sh.container(w["min"], w["max"], open_top=w["open_top"])
                lo, hi = np.array(w["min"]), np.array(w["max"])
                inside = (lambda lo, hi: lambda x: ((x > lo) & (x < hi)).all(1))(lo, hi)
            else:
                sdf = sh.box(w["min"], w["max"])
                inside = (lambda f: lambda x: f(x) > 0)(sdf)
        elif shape == "sphere":
            sdf = sh.sphere(w["center"], w["radius"])
            inside = (lambda f: lambda x: f(x) > 0)(sdf)
        elif shape == "cylinder":
            sdf = sh.cylinder(w["center"], w["radius"], w["height"], w["axis"])
            inside = (lambda f: lambda x: f(x) > 0)(sdf)
        elif shape in ("bowl", "glass", "hourglass"):
            t = w["thickness"] or thickness
            c = list(w["center"]) + [0.0] * (3 - dim)
            wall, cav = _revolved_profiles(w, t)
            sdf = sh.revolved_shell(wall, t, c)
            inside = sh.profile_interior(cav, c)
        elif shape == "terrain":
            h = sh.terrain_height([w["x"][0], w["z"][0]], [w["x"][1], w["z"][1]], w["base"], w["slope"],
                                  w["seed"] if w["seed"] is not None else s["seed"], w["roughness"],
                                  w["channels"], w["channel_depth"], w["channel_width"],
                                  w["depressions"], w["depression_depth"], w["depression_radius"])
            sz = w["slice_z"] if w["slice_z"] is not None else 0.5 * (w["z"][0] + w["z"][1])
            sdf = sh.heightfield(h, slice_z=sz)
            inside = (lambda f: lambda x: f(x) > 0)(sdf)
        elif shape == "mesh":
            mesh = _placed_mesh(f"walls.{name}", w, base_dir, meshes)
            sdf = _mesh_wall(name, w, mesh, dim, band, 2 * s["radius"])
            inside = (lambda f: lambda x: f(x) > 0)(sdf)
        else:  # pragma: no cover - validated before
            raise AssertionError(shape)
        out.append(_Solid(name, sdf, inside, mesh=getattr(sdf, "mesh", None)))
    return out


def _revolved_profiles(w: dict, t: float):
    """(wall centre-line, cavity profile) of a bowl, glass or hourglass wall of thickness
    ``t``, as (radius, height) polylines relative to its ``center``."""
    from ..geometry import shapes as sh
    if w["shape"] == "bowl":
        # centre-line of the wall half a thickness outside the cavity
        return (sh.bowl_profile(w["radius"] + t / 2) + np.array([0.0, -t / 2]),
                sh.bowl_profile(w["radius"]))
    if w["shape"] == "glass":
        wall, bowl = sh.glass_profile(w["bowl"], w["stem"], w["foot"])
        # cavity: the bowl's centre-line moved inwards by half the wall
        cav = bowl + np.array([0.0, t / 2])
        cav[:, 0] = np.maximum(cav[:, 0] - t / 2, 0)
        return wall, cav
    nh = w["neck_height"] or w["radius"]
    wall = sh.hourglass_profile(w["radius"] + t / 2, w["height"] + t, w["neck"] + t / 2, nh)
    cav = sh.hourglass_profile(w["radius"], w["height"], w["neck"], nh) + np.array([0.0, t / 2])
    return wall, cav


def _mesh_wall(name: str, w: dict, mesh, dim: int, band: float, spacing: float):
    """SDF of a mesh wall: the solid a closed mesh encloses (or, hollow, the space around
    it), or with ``thickness`` a shell behind (invert_normals: in front of) its faces."""
    from ..geometry import mesh as gm
    T = w["thickness"]
    if T is None:
        gm.require_closed(mesh, f"give walls.{name}.thickness to use it as an open surface "
                          "(a shell of that thickness behind its faces)")
        solid = gm.mesh_solid(mesh, band=band) if dim == 3 else gm.mesh_section(mesh, w["slice_z"])
        sdf = (lambda f: lambda x: -f(x))(solid) if w["hollow"] else solid
    else:
        if T < spacing - 1e-12:
            raise DcdcError(f"walls.{name}.thickness {T:g} is thinner than the particle spacing "
                            f"2r = {spacing:g}: the shell would have holes between lattice points")
        behind = not w["invert_normals"]
        sdf = gm.mesh_shell(mesh, T, behind, band=band) if dim == 3 else \
            gm.mesh_section_shell(mesh, T, w["slice_z"], behind)
    sdf.mesh = mesh
    return sdf


def _check_mesh_walls(solids, wx, src: str, lo, hi, spacing: float, thickness: float):
    """A mesh wall must give wall particles: else one line naming the likely cause."""
    for w in solids:
        if w.mesh is None:
            continue
        s = w.sdf(wx) if len(wx) else np.zeros(0)
        if ((s <= 1e-9) & (s >= -thickness - 1e-9)).any():
            continue
        m = w.mesh
        mlo, mhi = np.asarray(m.bounds[0]), np.asarray(m.bounds[1])
        d = len(lo)
        ext = mhi - mlo
        if (mhi[:d] < lo - thickness).any() or (mlo[:d] > hi + thickness).any():
            cause = (f"the mesh (bounds {np.round(mlo, 3).tolist()} .. {np.round(mhi, 3).tolist()}) "
                     f"lies outside the domain {np.round(lo, 3).tolist()} .. {np.round(hi, 3).tolist()}")
        elif ext[:d].min() < spacing:
            cause = (f"the mesh is thinner ({ext[:d].min():.3g}) than the particle spacing 2r = "
                     f"{spacing:g}: scale it up or use a smaller radius")
        else:
            cause = (f"no lattice point (spacing 2r = {spacing:g}) falls inside its solid; "
                     "the mesh is too small or too thin for this particle radius")
        raise DcdcError(f"{src}: walls.{w.name} (mesh {Path(m.metadata.get('dcdc_file', '?')).name}) "
                        f"yields no wall particles: {cause}")


def _union(solids):
    if not solids:
        return lambda x: np.full(len(x), np.inf)
    return lambda x: np.min(np.stack([w.sdf(x) for w in solids]), axis=0)


def _mesh_fill(field: str, f: dict, dim: int, spacing: float, anchor, base_dir, meshes):
    """Points of the global lattice at least r (half a spacing, as in a box) inside a
    closed mesh, or in 2-D inside its cross-section by the plane z = ``slice_z``."""
    from ..geometry import lattice, mesh as gm
    m = _placed_mesh(field, f, base_dir, meshes)
    try:
        inside = gm.mesh_interior(m, spacing / 2, None if dim == 3 else f["slice_z"])
    except DcdcError as e:
        raise DcdcError(f"{field}.file: {e}") from None
    pts = lattice(np.asarray(m.bounds[0][:dim]), np.asarray(m.bounds[1][:dim]), spacing, anchor)
    return pts[inside(pts)] if len(pts) else pts


def _on_one_face(points: np.ndarray, f: dict, spacing: float) -> bool:
    """Whether ``points`` all lie on one face plane of the ``fill`` block ``f``'s box: two
    stacked fills that share a face both take the lattice plane lying on it (at resolutions
    where one does); any other contact between blocks is a real overlap."""
    tol = 1e-6 * spacing
    for bound in (f["min"], f["max"]):
        if bound is not None and any(np.all(np.abs(points[:, a] - bound[a]) < tol)
                                     for a in range(points.shape[1])):
            return True
    return False


def _fluid_points(f: dict, dim: int, spacing: float, anchor, dom_lo, dom_hi, solids, union,
                  field: str = "fluid", base_dir: Path | None = None, meshes: dict | None = None):
    from ..geometry import lattice, shapes as sh
    shape = f["shape"]
    if shape == "mesh":
        pts = _mesh_fill(field, f, dim, spacing, anchor, base_dir, meshes)
        if f["clearance"] is not None and solids and len(pts):
            pts = pts[union(pts) >= f["clearance"] - 1e-9]
        return pts
    if shape == "box":
        lo, hi = np.array(f["min"]), np.array(f["max"])
        top, bot = f["top_wave"], f["bottom_wave"]
        if not (top or bot):
            return lattice(lo + spacing / 2, hi - spacing / 2, spacing, anchor)
        # wavy faces y = face + a cos(2 pi (x - min_x) / wavelength); flat faces as usual
        ext = np.zeros(dim)
        ext[1] = max(abs(top[0]) if top else 0.0, abs(bot[0]) if bot else 0.0) + spacing / 2
        pts = lattice(lo + spacing / 2 - ext, hi - spacing / 2 + ext, spacing, anchor)
        x0, y = pts[:, 0] - lo[0], pts[:, 1]
        keep = (y < hi[1] + top[0] * np.cos(2 * np.pi * x0 / top[1])) if top else \
            (y <= hi[1] - spacing / 2 + 1e-9)
        keep &= (y >= lo[1] + bot[0] * np.cos(2 * np.pi * x0 / bot[1])) if bot else \
            (y >= lo[1] + spacing / 2 - 1e-9)
        pts = pts[keep]
        return pts
    if shape == "sphere":
        c, r = np.array(f["center"]), f["radius"]
        pts = lattice(c - r, c + r, spacing, anchor)
        return pts[np.linalg.norm(pts - c, axis=1) <= r - spacing / 2 + 1e-9]
    if shape == "cylinder":
        c, r, h = np.array(f["center"]), f["radius"], f["height"]
        half = np.full(dim, r)
        half[f["axis"]] = h / 2
        pts = lattice(c - half, c + half, spacing, anchor)
        sdf = sh.cylinder(c, r - spacing / 2, h - spacing, f["axis"])
        return pts[sdf(pts) <= 1e-9]
    if shape == "fill":
        lo = np.array(f["min"]) if f["min"] is not None else dom_lo
        hi = np.array(f["max"]) if f["max"] is not None else dom_hi
        lo, hi = np.maximum(lo, dom_lo), np.minimum(hi, dom_hi)
        top, bot = f["top_wave"], f["bottom_wave"]
        ext = np.zeros(dim)
        ext[1] = max(abs(top[0]) if top else 0.0, abs(bot[0]) if bot else 0.0)
        pts = lattice(lo - ext, hi + ext, spacing, anchor)
        if top or bot:
            x0 = pts[:, 0] - lo[0]
            keep = pts[:, 1] < (hi[1] + top[0] * np.cos(2 * np.pi * x0 / top[1]) if top else hi[1])
            keep &= pts[:, 1] >= (lo[1] + bot[0] * np.cos(2 * np.pi * x0 / bot[1]) if bot else lo[1])
            pts = pts[keep]
        if not len(pts):
            return pts
        wall = next(w for w in solids if w.name == f["inside"])
        clearance = f["clearance"] if f["clearance"] is not None else spacing / 2
        keep = wall.inside(pts)
        pts = pts[keep]
        if len(pts):
            pts = pts[union(pts) >= clearance - 1e-9]
        return pts
    raise AssertionError(shape)


def _block_phases(f: dict, i: int, n: int, names: list, seed: int) -> np.ndarray:
    """Phase index of each of the ``n`` particles of fluid block ``i``: its phase, or for
    ``phases`` a random one per particle (drawn with ``fractions`` from [seed, i])."""
    if f["phases"] is None:
        return np.full(n, names.index(f["phase"]))
    idx = np.array([names.index(p) for p in f["phases"]])
    rng = np.random.default_rng([int(seed), 0xE5, i])
    return idx[rng.choice(len(idx), size=n, p=f["fractions"])]


def _releases(e: dict) -> int:
    """Releases of a mesh emitter: at start + k·interval before stop."""
    return int(math.ceil((e["stop"] - e["start"]) / e["interval"] - 1e-9))


def _mesh_emitter_points(e: dict, field: str, dim: int, spacing: float, anchor, base_dir, meshes):
    """A mesh emitter's particles: the mesh's fluid (as a [[fluid]] of shape "mesh"),
    once per release, born at start + k·interval."""
    pos = _mesh_fill(field, e, dim, spacing, anchor, base_dir, meshes)
    births = e["start"] + e["interval"] * np.arange(_releases(e))
    x = np.tile(pos, (len(births), 1))
    b = np.repeat(births, len(pos))
    v = np.tile(np.asarray(e["velocity"], dtype=np.float64), (len(x), 1))
    return x, v, b


def _budget_view(s: dict, base_dir: Path | None, meshes: dict) -> dict:
    """The scene as :mod:`.budget` counts it: a mesh fluid as the box of its mesh's
    bounds, a mesh emitter as that box stretched along x to hold all its releases."""
    if not any(f["shape"] == "mesh" for f in s["fluid"] + s["emitter"]):
        return s
    dim, sp = s["dim"], 2 * s["radius"]
    v = dict(s, fluid=[], emitter=[])
    for kind in ("fluid", "emitter"):
        for i, f in enumerate(s[kind]):
            if f["shape"] != "mesh":
                v[kind].append(f)
                continue
            m = _placed_mesh(f"{kind}[{i}]", f, base_dir, meshes)
            lo, hi = [float(c) for c in m.bounds[0][:dim]], [float(c) for c in m.bounds[1][:dim]]
            if kind == "emitter":  # n releases: floor(len / sp) + 1 points along x, n times
                n_x = math.floor(max(hi[0] - lo[0], 0.0) / sp) + 1
                hi[0] = lo[0] + (n_x * _releases(f) - 1) * sp
            v["fluid"].append({"shape": "box", "min": lo, "max": hi})
    return v


def _wall_bounds(name: str, w: dict, dim: int, thickness: float, base_dir, meshes, src: str):
    """Axis-aligned box (lo, hi) around a wall: a hollow box or closed mesh is its cavity
    (the solid lies outside), a mesh shell is its mesh grown by the shell's thickness."""
    from ..geometry import shapes as sh
    shape = w["shape"]
    if shape == "box":
        return np.array(w["min"]), np.array(w["max"])
    if shape == "sphere":
        c = np.array(w["center"])
        return c - w["radius"], c + w["radius"]
    if shape == "cylinder":
        return sh.cylinder_bounds(w["center"], w["radius"], w["height"], w["axis"])
    if shape in ("bowl", "glass", "hourglass"):
        t = w["thickness"] or thickness
        return sh.revolved_bounds(_revolved_profiles(w, t)[0], t, w["center"], dim)
    if shape == "mesh":
        m = _placed_mesh(f"walls.{name}", w, base_dir, meshes)
        grow = w["thickness"] or 0.0
        return np.asarray(m.bounds[0][:dim]) - grow, np.asarray(m.bounds[1][:dim]) + grow
    raise DcdcError(f"{src}: walls.{name} ({shape}) has no bounding box to derive the domain from "
                    "(its solid reaches down and sideways without end); give the scene a [domain] "
                    "with min and max")


def _fluid_bounds(f: dict, field: str, dim: int, base_dir, meshes):
    """Axis-aligned box around a fluid block, or None for a fill (it lies in its wall)."""
    from ..geometry import shapes as sh
    shape = f["shape"]
    if shape == "box":
        lo, hi = np.array(f["min"]), np.array(f["max"])
        lo[1] -= abs(f["bottom_wave"][0]) if f["bottom_wave"] else 0.0
        hi[1] += abs(f["top_wave"][0]) if f["top_wave"] else 0.0
        return lo, hi
    if shape == "sphere":
        c = np.array(f["center"])
        return c - f["radius"], c + f["radius"]
    if shape == "cylinder":
        return sh.cylinder_bounds(f["center"], f["radius"], f["height"], f["axis"])
    if shape == "mesh":
        m = _placed_mesh(field, f, base_dir, meshes)
        return np.asarray(m.bounds[0][:dim]), np.asarray(m.bounds[1][:dim])
    return None


def derive_domain(s: dict, base_dir: Path | None = None, meshes: dict | None = None,
                  src: str = "scene") -> dict:
    """The domain of a scene variant that gives no ``[domain]``: the axis-aligned box around
    every wall, fluid block and emitter (nozzle or mesh). A wall without a box (terrain)
    is a one-line :class:`DcdcError` asking for ``[domain]``."""
    dim, sp = s["dim"], 2 * s["radius"]
    thickness = s["wall_thickness"] or 2 * sp
    boxes = [_wall_bounds(n, w, dim, thickness, base_dir, meshes, src) for n, w in s["walls"].items()]
    boxes += [b for i, f in enumerate(s["fluid"])
              if (b := _fluid_bounds(f, f"fluid[{i}]", dim, base_dir, meshes)) is not None]
    for i, e in enumerate(s["emitter"]):
        if e["shape"] == "mesh":
            m = _placed_mesh(f"emitter[{i}]", e, base_dir, meshes)
            boxes.append((np.asarray(m.bounds[0][:dim]), np.asarray(m.bounds[1][:dim])))
        else:  # the nozzle's points, half a spacing around them
            x = nozzle_layer(e, dim, sp)
            boxes.append((x.min(0) - sp / 2, x.max(0) + sp / 2))
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    flat = [a for a, (l, h) in enumerate(zip(lo, hi)) if not h > l]
    if flat:
        raise DcdcError(f"{src}: the box around the walls and fluid is flat along {'xyz'[flat[0]]}; "
                        "give the scene a [domain] with min and max")
    return {"min": [float(v) for v in lo], "max": [float(v) for v in hi]}


def realize_variant(s: dict, text: str, src: str, base_dir: Path | None, meshes: dict,
                    resolution: float, scene_dim: int, check: bool = True,
                    frames: int | None = None, max_particles: float | None = None) -> ParticleSystem:
    """Particles of the scene variant ``s`` (:meth:`dcdc.scene.format.Scene.variant`): wall
    particles sampled on the union of its walls' solids, its fluid blocks on the global
    lattice (odd multiples of r), its emitters' particles with their birth times. ``text``
    and ``src`` name the blocks' lines and the file in messages; ``meshes`` caches the placed
    meshes; ``resolution`` and the scene's own ``scene_dim`` go into the system's ``meta``.
    The particle and memory budget (:mod:`.budget`; ``frames`` stored frames, a
    ``max_particles`` override) is checked before anything is allocated; with ``check``,
    empty blocks, overlaps and fluid inside walls or outside the domain raise
    :class:`DcdcError`."""
    from ..geometry import sample_walls
    from ..neighbors import radius_search
    from . import budget

    budget.check(_budget_view(s, base_dir, meshes), src, frames, max_particles)
    dim = s["dim"]
    r = s["radius"]
    spacing = 2 * r
    anchor = np.full(dim, r)  # global lattice: odd multiples of r
    thickness = s["wall_thickness"] or 4 * r
    lo, hi = np.array(s["domain"]["min"]), np.array(s["domain"]["max"])
    solids = _build_walls(s, base_dir, thickness, meshes)
    union = _union(solids)
    if solids:
        pad = thickness + spacing
        wx, wn = sample_walls(union, lo - pad, hi + pad, spacing, thickness, anchor,
                              fluid_box=(lo, hi))
        _check_mesh_walls(solids, wx, src, lo, hi, spacing, thickness)
    else:
        wx, wn = np.zeros((0, dim)), np.zeros((0, dim))
    names = list(s["phases"])
    phases = [Phase(n, p["density"], p["viscosity"], tuple(p["color"])) for n, p in s["phases"].items()]
    xs, vs, ph, births, blocks = [], [], [], [], []
    for i, f in enumerate(s["fluid"]):
        pts = _fluid_points(f, dim, spacing, anchor, lo, hi, solids, union, f"fluid[{i}]",
                            base_dir, meshes)
        label = f"fluid[{i}]" + (f" ({f['name'] or f['phase'] or '+'.join(f['phases'])})")
        line = find_line(text, f"fluid[{i}]")
        at = f" (line {line})" if line else ""
        if check and not len(pts):
            raise DcdcError(f"{src}: {label} holds no particles at this resolution{at}")
        if check and len(pts):
            # the domain first: beyond it a hollow wall's solid reaches to infinity, and
            # "inside the wall" would hide that the fluid is outside the domain
            out = ~((pts >= lo) & (pts <= hi)).all(1)
            if out.any():
                raise DcdcError(f"{src}: {label} has {int(out.sum())} particle(s) outside the "
                                f"domain{at}")
            if solids:
                d = union(pts)
                bad = d < 0.5 * r
                if bad.any():
                    j = int(np.flatnonzero(bad)[0])
                    which = min(solids, key=lambda w: float(w.sdf(pts[j:j + 1])[0])).name
                    raise DcdcError(f"{src}: {label} has {int(bad.sum())} particle(s) inside or "
                                    f"touching walls.{which}, e.g. at {pts[j].round(3).tolist()}{at}")
            for k, (lab2, prev) in enumerate(blocks):
                nb = radius_search(pts, 0.75 * spacing, prev)
                hit = nb.counts > 0
                if nb.n_edges and f["shape"] == "fill" and _on_one_face(pts[hit], f, spacing):
                    pts = pts[~hit]  # the shared face's plane belongs to the block listed first
                elif nb.n_edges:
                    raise DcdcError(f"{src}: {label} overlaps {lab2} "
                                    f"({int(hit.sum())} particles){at}")
        blocks.append((label, pts))
        xs.append(pts)
        vs.append(np.tile(np.asarray(f["velocity"], dtype=np.float64), (len(pts), 1)))
        ph.append(_block_phases(f, i, len(pts), names, s["seed"]))
        births.append(np.zeros(len(pts)))
    for i, e in enumerate(s["emitter"]):
        if e["shape"] == "mesh":
            x, v, b = _mesh_emitter_points(e, f"emitter[{i}]", dim, spacing, anchor, base_dir, meshes)
            what = "mesh volume"
            if check and not len(x):
                raise DcdcError(f"{src}: emitter[{i}] ({e['phase']}) holds no particles at this "
                                "resolution")
        else:
            x, v, b = nozzle_points(e, dim, spacing)
            what = "nozzle"
        if check and solids and len(x) and (union(x) < 0.5 * r).any():
            raise DcdcError(f"{src}: emitter[{i}] {what} lies inside a wall")
        if check and not ((x >= lo) & (x <= hi)).all():
            raise DcdcError(f"{src}: emitter[{i}] {what} lies outside the domain")
        xs.append(x)
        vs.append(v)
        ph.append(np.full(len(x), names.index(e["phase"])))
        births.append(b)
    cat = (lambda a, w: np.concatenate(a) if a else np.zeros((0, w)))
    system = ParticleSystem(
        dim=dim, radius=r, x=cat(xs, dim), v=cat(vs, dim),
        phase=np.concatenate(ph) if ph else np.zeros(0, int), phases=phases,
        wall_x=wx, wall_n=wn, gravity=np.asarray(s["gravity"], dtype=np.float64),
        domain=(lo - thickness, hi + thickness), birth=np.concatenate(births) if births else None, name=s["name"],
        meta={"scene": s["name"], "resolution": resolution, "scene_domain": [lo.tolist(), hi.tolist()], "scene_dim": scene_dim,
              "duration": s["duration"], "frame_dt": s["frame_dt"], "seed": s["seed"]},
        wall_sdf=union if solids else None)
    return system
