"""Scene families: the generalisation suite's scenes and training scenes drawn like them
(docs/evaluation.md, "Generalisation suite").

A family is a container and a kind of start; :func:`family_scene_text` draws one scene of
a family from a seed (the same seed, family and dimension always give the same file):

- containers: a closed box tank, the stemmed glass of the built-in cocktail in a closed
  case, the built-in hourglass (closed, filled to the top), procedural terrain in a closed
  box (the built-in canyon's shape), and a shipped OBJ mesh (``asset:capsule.obj``, lying
  on its side) as a closed vessel;
- starts: **layered** (horizontal layers in a random order, mostly wrong: some heavy phase
  above a light one), **emulsion** (one block in which every particle gets a random phase,
  a ``[[fluid]]`` block with ``phases = [...]``), **sloshing** (layers moving sideways at
  0.3-0.8 m/s) and **tilted** (layers whose interfaces are tilted by 8-20°: half a cosine
  wave across the container);
- 2-4 phases; the density ratio max/min is drawn log-uniformly from 1.1-1.5 for half the
  scenes and from 1.5-20 for the other half; densities lie in 500-5000 kg/m³ (the
  lightest down to 200 kg/m³ where a ratio above 8 needs it),
  viscosities in 1e-6-1e-4 m²/s;
- gentle: the fluid fills the container from its floor (2-D depth 0.6-1.2 m; the hourglass
  full), 600-1500 fluid particles in 2-D and 1500-6000 in 3-D at r = 2.5 cm, 4 s at frames
  of 0.02 s.

**One physics for every family scene.** Every pair of phases has the same interfacial
tension, the solver's default ``"curvature"`` model at σ = 20 N/m (as the built-in
hourglass), in the suite and in the training scenes drawn from these families; the
closed, filled hourglass also gets the built-in hourglass's closed-container settings.

**Seeds.** Training sets use seeds below :data:`SUITE_SEED0` (900 000); the suite's
scenes use seeds from :data:`SUITE_SEED0` upward, so no training run sees them.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import DcdcError
from ..particles import FRAME_DT
from .random import PALETTE, to_toml

FAMILIES = ("box_layered", "box_emulsion", "box_slosh", "box_tilted",
            "glass", "hourglass", "terrain", "mesh")
SUITE_SEED0 = 900_000  # suite seeds: >= SUITE_SEED0; training seeds: < SUITE_SEED0
TENSION = 20.0  # N/m, every phase pair, the solver's default ("curvature") model
RATIO_RANGE = (1.1, 20.0)
LOW_RATIO = 1.5  # half the scenes have ratios in RATIO_RANGE[0] .. LOW_RATIO
DENSITY_RANGE = (500.0, 5000.0)
VISCOSITY_RANGE = (1e-6, 1e-4)
PARTICLES = {2: (600, 1500), 3: (1500, 6000)}
MIN_PER_PHASE = {2: 30, 3: 100}
RADIUS = 0.025
SPACING = 2 * RADIUS
DURATION = 4.0
# the built-in hourglass's [solver] for a closed, completely filled container (its
# reference_density is 0.9 x the light phase's density: here 0.9 x the lightest phase's)
CLOSED_SOLVER = {"reference_surface": False, "reference_stratified": False, "xsph": 0.01,
                 "viscosity": 1e-4}
GLASS_BOWL = [[0.0, 0.0], [0.36, 0.04], [0.6, 0.17], [0.74, 0.38], [0.82, 0.72], [0.84, 1.25]]


def _snap(v: float) -> float:
    """A length on the lattice's cell boundaries (multiples of the spacing)."""
    return float(round(round(float(v) / SPACING) * SPACING, 6))


def _u(rng, a, b) -> float:
    return float(rng.uniform(a, b))


def _logu(rng, a, b) -> float:
    return float(np.exp(rng.uniform(math.log(a), math.log(b))))


def draw_densities(rng, n: int) -> list[float]:
    """``n`` distinct densities [kg/m³] (in a random order) whose max/min ratio is drawn
    log-uniformly from 1.1-1.5 (half the draws) or 1.5-20, within 500-5000 kg/m³ (the
    lightest down to 200 kg/m³ where a ratio above 8 needs it)."""
    lo, hi = DENSITY_RANGE
    for _ in range(100):
        R = _logu(rng, RATIO_RANGE[0], LOW_RATIO) if rng.uniform() < 0.5 else \
            _logu(rng, LOW_RATIO, RATIO_RANGE[1])
        floor = min(lo, 0.8 * hi / R)  # below 500 kg/m³ only where the ratio needs it
        rmin = float(round(_logu(rng, floor, hi / R)))
        rmax = float(min(max(round(rmin * R), math.ceil(RATIO_RANGE[0] * rmin)),
                         math.floor(RATIO_RANGE[1] * rmin), hi))
        mids = [float(round(_logu(rng, rmin, rmax))) for _ in range(n - 2)]
        vals = [rmin, rmax] + mids
        if len(set(vals)) == n and RATIO_RANGE[0] <= rmax / rmin <= RATIO_RANGE[1]:
            rng.shuffle(vals)
            return vals
    raise DcdcError("could not draw distinct densities")  # pragma: no cover


def _order(rng, dens: list[float]) -> list[int]:
    """Phase indices bottom to top: random, and with probability 0.8 not heavy-below."""
    k = len(dens)
    perm = [int(i) for i in rng.permutation(k)]
    right = lambda p: all(dens[p[j]] > dens[p[j + 1]] for j in range(k - 1))  # noqa: E731
    while right(perm) and rng.uniform() < 0.8:
        perm = [int(i) for i in rng.permutation(k)]
    return perm


def _cuts(rng, k: int, y0: float, y1: float) -> list[float]:
    """k layers between y0 and y1: the k + 1 boundaries, inner ones on the lattice's cell
    boundaries, each layer at least 3 spacings thick (or as equal as it fits)."""
    f = rng.dirichlet([4.0] * k)
    f = 0.5 * f + 0.5 / k  # no layer under half the average
    cum = np.cumsum(f)[:-1]
    inner = [_snap(y0 + c * (y1 - y0)) for c in cum]
    out = [y0] + inner + [y1]
    if any(b - a < 3 * SPACING for a, b in zip(out, out[1:])):
        out = [y0] + [_snap(y0 + j * (y1 - y0) / k) for j in range(1, k)] + [y1]
    return out


def _vec(dim, x, y, z=0.0) -> list[float]:
    return [float(x), float(y)] + ([float(z)] if dim == 3 else [])


def _blocks(rng, start: str, inside: str, dim: int, x_range, z_range, cuts, order, names,
            velocity=None, wave=None) -> list[dict]:
    """The [[fluid]] blocks of a start: fills of ``inside`` between the y ``cuts`` (bottom
    to top; ``order`` the phase index of each layer), or one emulsion fill between the
    first and last cut. ``wave``: [amplitude, wavelength] of every inner interface."""
    x0, x1 = x_range
    z0, z1 = z_range
    vel = velocity or [0.0] * dim
    if start == "emulsion":
        fr = rng.dirichlet([3.0] * len(names))
        fr = [round(float(0.5 * v + 0.5 / len(names)), 3) for v in fr]
        return [{"phases": list(names), "fractions": fr, "shape": "fill", "inside": inside,
                 "min": _vec(dim, x0, cuts[0], z0), "max": _vec(dim, x1, cuts[-1], z1),
                 "velocity": vel}]
    out = []
    for j, ph in enumerate(order):
        b = {"phase": names[ph], "shape": "fill", "inside": inside,
             "min": _vec(dim, x0, cuts[j], z0), "max": _vec(dim, x1, cuts[j + 1], z1),
             "velocity": vel}
        if wave is not None and j > 0:
            b["bottom_wave"] = list(wave)
        if wave is not None and j < len(order) - 1:
            b["top_wave"] = list(wave)
        out.append(b)
    return out


def _start_of(family: str, rng) -> str:
    if family.startswith("box_"):
        return {"layered": "layered", "emulsion": "emulsion", "slosh": "sloshing",
                "tilted": "tilted"}[family[4:]]
    if family == "hourglass":
        return "layered" if rng.uniform() < 0.75 else "emulsion"
    return str(rng.choice(["layered", "emulsion", "sloshing", "tilted"]))


def _motion(rng, start: str, dim: int, width: float, cuts):
    """(velocity, wave) of a start: sideways 0.3-0.8 m/s for sloshing; for tilted an
    interface wave of half a cosine across ``width`` whose mean slope is 8-20°, no more
    than 0.8 x the thinner of the bottom and top layers."""
    if start == "sloshing":
        u = _u(rng, 0.3, 0.8) * (1 if rng.uniform() < 0.5 else -1)
        return _vec(dim, round(u, 3), 0.0), None
    if start == "tilted" and len(cuts) > 2:
        theta = math.radians(_u(rng, 8.0, 20.0))
        a = min(0.5 * width * math.tan(theta),
                0.8 * (cuts[1] - cuts[0]), 0.8 * (cuts[-1] - cuts[-2]))
        a *= 1 if rng.uniform() < 0.5 else -1
        return None, [round(a, 4), round(2 * width, 4)]
    return None, None


def _box(rng, dim, start, k):
    if dim == 2:
        W, depth, D = _snap(_u(rng, 1.6, 2.8)), _snap(_u(rng, 0.6, 1.2)), None
    else:
        W, depth, D = _snap(_u(rng, 0.8, 1.3)), _snap(_u(rng, 0.4, 0.8)), _snap(_u(rng, 0.5, 0.9))
    H = _snap(depth + _u(rng, 0.5, 0.8))
    lo, hi = _vec(dim, 0, 0, 0), _vec(dim, W, H, D or 0)
    walls = {"tank": {"shape": "box", "min": lo, "max": hi, "hollow": True, "open_top": False}}
    cuts = _cuts(rng, k, 0.0, depth)
    return walls, {"min": lo, "max": hi}, "tank", (0.0, W), (0.0, D or 0.0), cuts, W, \
        f"box tank {W:g} m wide, {depth:g} m deep", {}


def _glass(rng, dim, start, k):
    s = _u(rng, 1.3, 1.6) if dim == 2 else _u(rng, 0.75, 0.95)
    s = round(s, 3)
    bowl = [[round(a * s, 4), round(b * s, 4)] for a, b in GLASS_BOWL]
    stem, foot = round(0.3 * s, 4), round(0.45 * s, 4)
    half, top = _snap(1.05 * s), _snap(2.0 * s)
    lo, hi = _vec(dim, -half, 0, -half), _vec(dim, half, top, half)
    walls = {"case": {"shape": "box", "min": lo, "max": hi, "hollow": True, "open_top": False},
             "glass": {"shape": "glass", "center": _vec(dim, 0, 0, 0), "foot": foot, "stem": stem,
                       "bowl": bowl}}
    bottom = stem + 2 * RADIUS  # the cavity's bottom (half the wall above the stem)
    depth = _u(rng, 0.45, 0.65) * bowl[-1][1]
    level = _snap(bottom + depth)
    cuts = _cuts(rng, k, bottom, level)
    cuts[0] = 0.0  # the bottom layer reaches down into the bowl's lowest point
    width = 2 * bowl[-1][0]
    return walls, {"min": lo, "max": hi}, "glass", (-half, half), (-half, half), cuts, width, \
        f"stemmed glass (x{s:g} the cocktail's), filled {level - bottom:.2f} m", {}


def _hourglass(rng, dim, start, k, dens):
    s = round(_u(rng, 1.05, 1.35) if dim == 2 else _u(rng, 0.7, 0.85), 3)
    R, Hc, neck, nh = round(0.5 * s, 4), _snap(1.8 * s), 0.2, round(0.4 * s, 4)
    t = 4 * RADIUS
    m = _snap(0.65 * s)
    lo, hi = _vec(dim, -m, -0.15, -m), _vec(dim, m, _snap(Hc + 0.2), m)
    walls = {"hourglass": {"shape": "hourglass", "center": _vec(dim, 0, 0, 0), "radius": R,
                           "height": Hc, "neck": neck, "neck_height": nh}}
    mid = _snap(t / 2 + Hc / 2)
    n_low = {2: 1, 3: int(rng.integers(1, 3)), 4: 2}[k]
    low = _cuts(rng, n_low, -0.1, mid)
    high = _cuts(rng, k - n_low, mid, Hc)
    cuts = low[:-1] + high
    solver = dict(CLOSED_SOLVER, reference_density=round(0.9 * min(dens), 1))
    return walls, {"min": lo, "max": hi}, "hourglass", (-m, m), (-m, m), cuts, 2 * R, \
        f"closed hourglass (x{s:g} the built-in), full", solver, mid


def _terrain(rng, dim, start, k, seed):
    from ..geometry.shapes import terrain_height
    if dim == 2:
        W, Dz, depth = _snap(_u(rng, 2.4, 3.2)), 1.0, _u(rng, 0.6, 1.0)
    else:
        W, Dz, depth = _snap(_u(rng, 1.6, 2.2)), _snap(_u(rng, 0.8, 1.1)), _u(rng, 0.4, 0.6)
    slope = round(_u(rng, 0.03, 0.1), 3)
    base = round(0.35 + slope * W, 3)
    ter = {"shape": "terrain", "x": [0.0, W], "z": [0.0, Dz], "base": base, "slope": slope,
           "roughness": 0.03, "channels": int(rng.integers(1, 3)), "channel_depth": 0.1,
           "channel_width": 0.3, "depressions": int(rng.integers(1, 4)),
           "depression_depth": 0.12, "depression_radius": 0.3}
    h = terrain_height([0.0, 0.0], [W, Dz], base, slope, seed, ter["roughness"], ter["channels"],
                       ter["channel_depth"], ter["channel_width"], ter["depressions"],
                       ter["depression_depth"], ter["depression_radius"])
    xs = np.linspace(0, W, 200)
    zs = np.array([0.5 * Dz]) if dim == 2 else np.linspace(0, Dz, 50)
    X, Z = np.meshgrid(xs, zs)
    ground = float(np.min(h(X.ravel(), Z.ravel())))
    level = _snap(ground + depth)
    H = _snap(level + _u(rng, 0.5, 0.8))
    lo, hi = _vec(dim, 0, -0.4, 0), _vec(dim, W, H, Dz)
    walls = {"terrain": ter, "sides": {"shape": "box", "min": lo, "max": hi, "hollow": True,
                                      "open_top": False}}
    cuts = _cuts(rng, k, _snap(ground + 0.1 * depth), level)
    cuts[0] = -0.4
    return walls, {"min": lo, "max": hi}, "terrain", (0.0, W), (0.0, Dz), cuts, W, \
        f"terrain {W:g} m long, slope {slope:g}, filled to {level:g} m", {}


def _mesh(rng, dim, start, k):
    # asset:capsule.obj: radius 0.5 about the z axis, z in [-1, 1]; scaled, then turned
    # about y by 90 degrees so that it lies along x
    if dim == 2:
        a, b, c = 1.0, round(_u(rng, 1.2, 1.5), 3), round(_u(rng, 1.1, 1.5), 3)
    else:
        a, b, c = round(_u(rng, 0.8, 1.0), 3), round(_u(rng, 0.8, 1.0), 3), round(_u(rng, 0.7, 1.0), 3)
    yc = round(0.5 * b, 4)
    walls = {"vessel": {"shape": "mesh", "file": "asset:capsule.obj", "scale": [a, b, c],
                        "rotation_axis": [0.0, 1.0, 0.0], "rotation_degrees": 90.0,
                        "translate": [0.0, yc, 0.0], "hollow": True}}
    lo, hi = _vec(dim, -c, 0, -a / 2), _vec(dim, c, b, a / 2)
    depth = _u(rng, 0.45, 0.6) * b
    cuts = _cuts(rng, k, 0.0, _snap(depth))
    return walls, {"min": lo, "max": hi}, "vessel", (-c, c), (-a / 2, a / 2), cuts, 2 * c, \
        f"capsule mesh vessel {2 * c:g} x {b:g} m, filled {_snap(depth):g} m", {}


def family_scene(family: str, seed: int, dim: int) -> dict:
    """One scene of ``family`` as a plain dict in the scene-file layout, its [solver]
    included; realised and checked (particle counts per scene and per phase, density
    ratio) before it is returned; a draw that fails is redrawn from the same stream."""
    from .format import Scene
    from .schema import validate
    if family not in FAMILIES:
        raise DcdcError(f"unknown scene family {family!r} (families: {', '.join(FAMILIES)})")
    if dim not in (2, 3):
        raise DcdcError(f"dim must be 2 or 3 (got {dim})")
    seed = int(seed)
    rng = np.random.default_rng([seed, 0xFA, FAMILIES.index(family), dim])
    lo_n, hi_n = PARTICLES[dim]
    why = ""
    for attempt in range(40):
        scene = _draw(family, seed, dim, rng)
        try:
            system = Scene(validate(scene, "", f"{family} seed {seed}")).realize()
        except DcdcError as e:
            why = str(e)
            continue
        n = system.n_fluid
        counts = np.bincount(system.phase, minlength=len(scene["phases"]))
        if lo_n <= n <= hi_n and counts.min() >= MIN_PER_PHASE[dim]:
            return scene
        why = f"{n} fluid particles, per phase {counts.tolist()}"
    raise DcdcError(f"could not draw a {dim}-D {family} scene for seed {seed} in 40 attempts "
                    f"(last: {why})")


def _draw(family: str, seed: int, dim: int, rng) -> dict:
    k = int(rng.choice([2, 3, 4], p=[0.45, 0.3, 0.25]))
    dens = draw_densities(rng, k)
    names = [f"phase{i}" for i in range(k)]
    phases = {n: {"density": rho, "viscosity": float(f"{_logu(rng, *VISCOSITY_RANGE):.3g}"),
                  "color": PALETTE[i]} for i, (n, rho) in enumerate(zip(names, dens))}
    start = _start_of(family, rng)
    mid = None
    if family.startswith("box_"):
        walls, dom, inside, xr, zr, cuts, width, what, solver = _box(rng, dim, start, k)
    elif family == "glass":
        walls, dom, inside, xr, zr, cuts, width, what, solver = _glass(rng, dim, start, k)
    elif family == "hourglass":
        walls, dom, inside, xr, zr, cuts, width, what, solver, mid = _hourglass(rng, dim, start, k, dens)
    elif family == "terrain":
        walls, dom, inside, xr, zr, cuts, width, what, solver = _terrain(rng, dim, start, k, seed)
    else:
        walls, dom, inside, xr, zr, cuts, width, what, solver = _mesh(rng, dim, start, k)
    order = _order(rng, dens)
    velocity, wave = _motion(rng, start, dim, xr[1] - xr[0], cuts)
    if family == "hourglass" and start == "layered":  # the built-in's wave at the neck
        s = width
        blocks = _blocks(rng, start, inside, dim, xr, zr, cuts, order, names)
        j = cuts.index(mid)
        w = [round(0.1 * s, 4), round(0.8 * s, 4)]
        blocks[j - 1]["top_wave"] = w
        blocks[j]["bottom_wave"] = w
    else:
        blocks = _blocks(rng, start, inside, dim, xr, zr, cuts, order, names, velocity, wave)
    ratio = max(dens) / min(dens)
    order_txt = "" if start == "emulsion" else \
        " bottom to top " + ", ".join(f"{dens[i]:g}" for i in order)
    solver = dict(solver)
    solver["interfacial_tension"] = {f"{a}/{b}": TENSION for i, a in enumerate(names)
                                     for b in names[i + 1:]}
    return {
        "name": f"{family}_{seed}",
        "description": (f"family {family}, seed {seed}, {dim}-D: {what}; {start} start of {k} phases"
                        f" (density ratio {ratio:.2f};{order_txt})"),
        "dim": dim, "radius": RADIUS, "duration": DURATION, "frame_dt": FRAME_DT, "seed": seed,
        "domain": dom, "phases": phases, "walls": walls, "fluid": blocks, "solver": solver,
    }


def family_scene_text(family: str, seed: int, dim: int) -> str:
    """The scene file text of :func:`family_scene` (deterministic per family, seed, dim)."""
    s = family_scene(family, seed, dim)
    solver = s.pop("solver")
    tension = solver.pop("interfacial_tension")
    text = to_toml(s, f"# generated by dcdc.scene.families.family_scene_text({family!r}, {seed}, {dim})")
    text += "\n[solver]\n" + "".join(f"{k} = {_toml(v)}\n" for k, v in solver.items())
    text += ("# every phase pair: the default (\"curvature\") model at 20 N/m, in every family scene\n"
             "[solver.interfacial_tension]\n"
             + "".join(f'"{k}" = {v!r}\n' for k, v in tension.items()))
    return text


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v) if not isinstance(v, str) else f'"{v}"'


def family_of_index(i: int) -> str:
    """The family of the suite's i-th scene (the families in turn)."""
    return FAMILIES[i % len(FAMILIES)]


def density_ratio(text: str) -> float:
    """max/min density of a scene file's phases."""
    from .format import tomllib
    d = [p["density"] for p in tomllib.loads(text)["phases"].values()]
    return max(d) / min(d)
