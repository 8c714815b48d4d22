"""SPlisHSPlasH scene JSON (its ``doc/file_format.md``; the scenes in its data/Scenes) as a
dcdc scene.

What maps:

* ``Configuration``: ``particleRadius`` → radius, ``gravitation`` → gravity, ``stopAt`` →
  duration (else 2 s), ``dataExportFPS`` → frame_dt; into ``[solver]``: ``simulationMethod``
  0 → WCSPH (``exponent`` → stiffness_exponent), 4 → DFSPH; ``cflFactor`` f → cfl = 0.4 f
  (their CFL step is 0.4 f · 2r / v_max, ours cfl · 2r / v_max), ``cflMaxTimeStepSize`` /
  ``cflMinTimeStepSize`` → dt_max / dt_min, ``maxIterations`` → max_iterations, ``maxError``
  / ``maxErrorV`` (percent) → density_tolerance / divergence_tolerance, ``enableDivergenceSolver``
  → divergence_solve, ``boundaryHandlingMethod`` 0 (Akinci 2012 particles) → boundary =
  "particles", 2 (volume maps) → "map". Newer files keep the solver's parameters in a
  block named for it (``"DFSPH": {...}``): the chosen solver's block is read.
* ``Materials`` (and the older ``Fluid`` / per-id blocks and material keys in
  ``Configuration``): one phase per id, ``density0`` (default 1000) → density,
  ``viscosity`` with ``viscosityMethod`` 1 (standard, a kinematic viscosity) → viscosity;
  ``maxEmitterParticles`` caps that phase's emitters. Newer files keep each force method's
  parameters in a block named for it (``"Standard viscosity": {"viscosity": ...}``): the
  chosen methods' blocks are read, and the newer method numbers apply (no XSPH viscosity).
  SPlisHSPlasH's defaults apply where a material leaves them out (and to an id without a
  material): ``viscosityMethod`` 1 (standard) with ``viscosity`` 0.01 m²/s, so such a phase
  gets ν = 0.01 (a note in the TOML names it). Its standard viscosity acts between
  particles of the same fluid only; dcdc's also between phases (a note when the scene has
  more than one viscous phase).
* ``RigidBodies`` (static; a dynamic one becomes a static wall, with a warning):
  ``geometryFile`` with ``scale`` (per axis), ``rotationAxis`` / ``rotationAngle``
  (radians), ``translation`` → a ``mesh`` wall. A closed mesh is a container (``hollow``)
  when ``mapInvert`` says so — with particle boundaries, or without ``mapInvert``, when most
  of the fluid (by volume) lies inside it — else a solid; an open mesh is a 4r shell on the side away from
  the fluid.
* ``FluidBlocks``: ``start`` / ``end`` scaled and translated → a ``box`` block that holds the
  particles SPlisHSPlasH samples there: along an edge of length L, round(L/2r) − 1
  particles at spacing 2r from 2r inside ``start`` (its ``denseMode`` 0 rule; a block with at
  most one per axis is empty there and left out here; the other dense modes are a warning
  with both counts), on the points of dcdc's lattice (odd multiples of r) nearest them, up
  to r nearer ``start`` (a note), ``initialVelocity`` → velocity (a block reaching into a closed wall: a ``fill`` of its box
  inside its container, without the particles in walls; one mostly in a wall: left out); ``FluidModels`` with a mesh ``particleFile`` (OBJ, PLY,
  STL, OFF) → a ``mesh`` block (scaled, rotated, translated).
* ``Emitters``: position ``translation``, direction the first column of the rotation (or
  the older ``direction``), ``velocity`` → speed, ``emitStartTime`` / ``emitEndTime`` →
  start / stop, ``emitsPerSecond`` → rate; a circle of ``width`` w particles is a round
  nozzle of radius w·r, a box (``type`` 0) of w × h particles a box nozzle of w·2r × h·2r
  (height side along the rotation's second column). SPlisHSPlasH also places a static
  housing (its ``EmitterBox.obj`` / ``EmitterCylinder.obj``) around each emitter, which
  stays in the flow after the emitter stops: a warning naming its size (dcdc's nozzles have
  no walls).
* ``sim2D``: a 2-D scene (``dim = 2``, the plane z = 0; meshes are sectioned there, z
  components dropped). As SPlisHSPlasH does in 2-D, every emitter turns about z and is a
  segment of height (a circle: width) particles, a 2-D box nozzle.
* No ``[domain]`` is written: dcdc derives the box around walls and fluid. A scene without
  a closed container gets ``[solver] on_escape = "remove"`` (fluid leaving that box is
  dropped; SPlisHSPlasH has no domain).

Everything else that changes the physics (other solvers and viscosity methods, surface
tension, vorticity, drag, elasticity, animation fields, dynamic bodies, particle
files, particle reuse) is one warning line per item; viewer and export settings are
named together in one line.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ...errors import DcdcError
from .common import Reader, finish, scene_name, toml_path, unique

FMT = "SPlisHSPlasH"
DEFAULT_ID = "Fluid"
SECTIONS = {"Configuration", "Simulation", "Materials", "Fluid", "RigidBodies", "FluidBlocks",
            "FluidModels", "Emitters", "AnimationFields"}
# PositionBasedDynamics sections (dynamic bodies, cloth, joints) that SPlisHSPlasH passes on
PBD_SECTIONS = {"TriangleModels", "TetModels", "BallJoints", "BallOnLineJoints", "HingeJoints",
                "UniversalJoints", "SliderJoints", "RigidBodyParticleBallJoints", "RigidBodySprings",
                "DistanceJoints", "DamperJoints", "TargetAngleMotorHingeJoints",
                "TargetVelocityMotorHingeJoints", "TargetPositionMotorSliderJoints",
                "TargetVelocityMotorSliderJoints"}
CONFIG_VIEWER = {"pause", "pauseAt", "cameraPosition", "cameraLookat", "numberOfStepsPerRenderUpdate",
                 "renderWalls", "enablePartioExport", "enableVTKExport", "enableRigidBodyExport",
                 "enableRigidBodyVTKExport", "particleAttributes", "enableStateExport",
                 "stateExportFPS", "enableZSort", "enableAsyncExport", "enableObjectSplitting",
                 "partioExportFPS", "comment"}
CONFIG_KEYS = {"particleRadius", "gravitation", "stopAt", "dataExportFPS", "simulationMethod",
               "cflMethod", "cflFactor", "cflMinTimeStepSize", "cflMaxTimeStepSize", "maxIterations",
               "maxError", "maxIterationsV", "maxErrorV", "enableDivergenceSolver",
               "boundaryHandlingMethod", "exponent", "stiffness", "sim2D", "timeStepSize",
               "velocityUpdateMethod", "kernel", "gradKernel", "minIterations", "lambda",
               "pressureClamping"}
MATERIAL_VIEWER = {"colorField", "colorMapType", "renderMinValue", "renderMaxValue", "visible",
                   "comment"}
MATERIAL_KEYS = {"id", "density0", "viscosity", "viscosityMethod", "viscosityBoundary",
                 "viscoMaxIter", "viscoMaxError", "viscoMaxIterOmega", "viscoMaxErrorOmega",
                 "surfaceTension", "surfaceTensionMethod", "surfaceTensionBoundary", "vorticity",
                 "vorticityMethod", "viscosityOmega", "inertiaInverse", "drag", "dragMethod",
                 "elasticityMethod", "youngsModulus", "poissonsRatio", "alpha", "elasticityMaxIter",
                 "elasticityMaxError", "maxEmitterParticles", "emitterReuseParticles",
                 "emitterBoxMin", "emitterBoxMax", "xsph", "xsphBoundary",
                 re.compile(r"^surfT"), re.compile(r"^visco"), re.compile(r"^elasticity")}
BODY_VIEWER = {"color", "isWall", "samplingMode", "mapResolution", "flatShading", "comment"}
BODY_KEYS = {"id", "geometryFile", "particleFile", "translation", "scale", "rotationAxis",
             "rotationAngle", "isDynamic", "mapInvert", "mapThickness", "friction", "restitution",
             "density", "velocity", "angularVelocity", "collisionObjectType",
             "collisionObjectScale", "invertSDF", "isAnimated"}
BLOCK_KEYS = {"id", "start", "end", "translation", "scale", "denseMode", "initialVelocity",
              "initialAngularVelocity"}
MODEL_KEYS = {"id", "particleFile", "translation", "scale", "rotationAxis", "rotationAngle",
              "initialVelocity", "initialAngularVelocity", "denseMode", "resolutionSDF", "invert"}
EMITTER_KEYS = {"id", "width", "height", "translation", "rotationAxis", "rotationAngle",
                "velocity", "direction", "emitStartTime", "emitEndTime", "type", "emitsPerSecond",
                "comment"}
FIELD_KEYS = {"particleField", "translation", "rotationAxis", "rotationAngle", "scale", "shapeType",
              "expression_x", "expression_y", "expression_z", "startTime", "endTime", "comment"}
MESH_EXT = (".obj", ".ply", ".stl", ".off")
METHODS = {0: "WCSPH", 1: "PCISPH", 2: "PBF", 3: "IISPH", 4: "DFSPH", 5: "Projective Fluids",
           6: "ICSPH"}
# the parameters of the pressure solver (Configuration) and of the non-pressure forces (a
# material) in newer files: a block named for the method; only the chosen method's is read
SOLVER_SECTION_KEYS = {"stiffness", "exponent", "minIterations", "maxIterations", "maxError",
                       "maxIterationsV", "maxErrorV", "enableDivergenceSolver",
                       "velocityUpdateMethod", "lambda", "pressureClamping"}
# older files (flat material keys): XSPH was viscosity method 2
VISCOSITY = {1: "standard", 2: "XSPH", 3: "Bender and Koschier 2017", 4: "Peer et al. 2015",
             5: "Peer et al. 2016", 6: "Takahashi et al. 2015", 7: "Weiler et al. 2018"}
# newer files (method blocks; XSPH is its own block): the method numbers and block names
FORCE_METHODS = {
    "viscosityMethod": {1: "Standard viscosity", 2: "Bender and Koschier 2017", 3: "Peer et al. 2015",
                        4: "Peer et al. 2016", 5: "Takahashi et al. 2015 (improved)",
                        6: "Weiler et al. 2018"},
    "vorticityMethod": {1: "Bender et al. 2017", 2: "Vorticity confinement", 3: "Liu et al. 2021"},
    "dragMethod": {1: "Macklin et al. 2014", 2: "Gissler et al. 2017"},
    "surfaceTensionMethod": {1: "Becker & Teschner 2007", 2: "Akinci et al. 2013", 3: "He et al. 2014",
                             4: "Jeske et al. 2023", 5: "Zorilla, Ritter, et al. 2020"},
    "elasticityMethod": {1: "Becker et al. 2009", 2: "Peer et al. 2018", 3: "Kugelstadt et al. 2021"}}
DEFAULT_VISCOSITY_METHOD, DEFAULT_VISCOSITY = 1, 0.01  # what SPlisHSPlasH applies unless told
MATERIAL_SECTIONS = {"XSPH"} | {n for m in FORCE_METHODS.values() for n in m.values()}
# parameters of methods dcdc warns about as a whole (their blocks are not checked key by key)
FORCE_WARNED = {"vorticityMethod", "dragMethod", "surfaceTensionMethod", "elasticityMethod"}


DENSE_MODES = {0: "regular", 1: "almost dense", 2: "dense"}


def block_counts(lo, hi, r: float, mode: int = 0) -> np.ndarray:
    """Particles per axis that SPlisHSPlasH samples in the fluid block [lo, hi] (3-D, after
    scale and translation) of particle radius ``r``: round(L/s) − 1 along an edge of length
    L at step s (2r; its denser modes step √3 r vertically, mode 2 also 2√6 r/3 along x,
    and take 2r off x and z first). At most one along any axis: SPlisHSPlasH leaves the
    block empty (in 2-D too, where it then keeps one layer in z)."""
    d = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
    step = np.full(3, 2.0 * r)
    if mode in (1, 2):
        step[1] = math.sqrt(3.0) * r
        if mode == 2:
            step[0] = math.sqrt(6.0) * 2.0 * r / 3.0
        d = d - np.array([step[0], 0.0, 2.0 * r])
    return (np.floor(d / step + 0.5) - 1).astype(int)  # C's round: halves away from zero


def emitter_housing(kind: int, width: int, height: int, r: float, particle_walls: bool) -> list:
    """Size (along the jet, then across: height side, width side) of the static housing
    SPlisHSPlasH places around an emitter (its ``Emitter::getSize``): 2h long (h = 4r, the
    support radius) and a margin of 2r (1.25 · 2r with volume or density maps) around the
    nozzle; a circle's housing is a cylinder (2.25× longer and wider with maps)."""
    d, h = 2.0 * r, 4.0 * r
    if kind == 0:
        m = 2 * d if particle_walls else 2.5 * d
        return [2 * h, height * d + m, width * d + m]
    rad = 0.5 * width * d + d
    return [2 * h, 2 * rad, 2 * rad] if particle_walls else [2.25 * h, 2.25 * rad, 2.25 * rad]


def is_splishsplash(data) -> bool:
    return isinstance(data, dict) and bool(set(data) & (SECTIONS - {"Fluid"}))


class _Import:
    """One conversion: the reader, the warnings, the viewer keys left out."""

    def __init__(self, path: Path, output: Path | None):
        self.rd = Reader(path.name)
        self.path, self.base, self.output = path, path.parent, output
        self.warnings: list[str] = []
        self.notes: list[str] = []
        self.viewer: list[str] = []

    def warn(self, msg: str):
        self.warnings.append(msg)

    def keys(self, obj: dict, where: str, known: set, viewer: set, what: str):
        self.rd.keys(obj, where, known | viewer, f"SPlisHSPlasH {what}")
        self.viewer += [f"{where}.{k}" for k in obj if k in viewer and k != "comment"]

    def file(self, name: str, where: str) -> Path:
        p = Path(name)
        p = p if p.is_absolute() else self.base / p
        if not p.exists():
            raise DcdcError(f"{self.path.name}: {where}: mesh file {p} not found")
        return p

    def placement(self, obj: dict, where: str):
        """(scale as dcdc writes it, translation, rotation axis, degrees) of an item."""
        rd = self.rd
        s = rd.vec3(obj, "scale", where, [1.0, 1.0, 1.0], scalar_ok=True)
        if any(c <= 0 for c in s):
            rd.fail(f"{where}.scale", f"must be > 0 in every axis (got {s}; mirroring is not mapped)")
        t = rd.vec3(obj, "translation", where, [0.0, 0.0, 0.0])
        axis = rd.vec3(obj, "rotationAxis", where, [0.0, 0.0, 1.0])
        deg = math.degrees(rd.number(obj, "rotationAngle", where, 0.0))
        if deg and not any(axis):
            rd.fail(f"{where}.rotationAxis", "must be a non-zero vector")
        return (s[0] if s[0] == s[1] == s[2] else s), t, axis, deg


def _placed(scale, t, axis, deg) -> dict:
    d = {"scale": scale, "translate": t}
    if deg:
        d.update(rotation_axis=axis, rotation_degrees=round(deg, 9))
    return d


def _config(im: _Import, cfg: dict) -> dict:
    """``Configuration`` with its keys checked and the chosen pressure solver's block (newer
    files: ``"DFSPH": {"maxError": ...}``) read into it; other solvers' blocks are unused."""
    rd = im.rd
    flat = {k: v for k, v in cfg.items() if k not in METHODS.values()}
    im.keys(flat, "Configuration", CONFIG_KEYS | MATERIAL_KEYS, CONFIG_VIEWER | MATERIAL_VIEWER,
            "Configuration")
    active = METHODS.get(rd.integer(flat, "simulationMethod", "Configuration", 4))
    for name in METHODS.values():
        if name in cfg:
            sec = rd.table(cfg[name], f"Configuration.{name}")
            if name == active:
                im.keys(sec, f"Configuration.{name}", SOLVER_SECTION_KEYS, {"comment"},
                        f"{name} parameter")
                flat.update(sec)
    return flat


def _material(im: _Import, m: dict, where: str) -> tuple[dict, bool]:
    """A material's keys checked, the blocks of its chosen methods (newer files: e.g.
    ``"Standard viscosity": {"viscosity": 0.01}``) read into it; (flat table, whether it
    had method blocks: then the newer method numbers apply)."""
    rd = im.rd
    flat = {k: v for k, v in m.items() if k not in MATERIAL_SECTIONS}
    im.keys(flat, where, MATERIAL_KEYS, MATERIAL_VIEWER, "material")
    blocks = {k: rd.table(v, f"{where}.{k}") for k, v in m.items() if k in MATERIAL_SECTIONS}
    if not blocks:
        return flat, False
    default = {"viscosityMethod": DEFAULT_VISCOSITY_METHOD}  # SPlisHSPlasH's; the others: none
    chosen = [("XSPH", False)] + [(FORCE_METHODS[key].get(rd.integer(flat, key, where, default.get(key, 0))),
                                   key in FORCE_WARNED) for key in FORCE_METHODS]
    for name, warned in chosen:
        if name in blocks:
            sec = blocks[name]
            if not warned:  # a method that dcdc reads: its keys must be ones dcdc knows
                im.keys(sec, f"{where}.{name}", MATERIAL_KEYS, {"comment"}, f"{name} parameter")
            flat.update(sec)
    return flat, True


def _materials(im: _Import, data: dict, ids_used: set) -> dict:
    """id -> (where, parameter table), later definitions of an id overriding earlier ones."""
    rd = im.rd
    out: dict = {}
    cfg = data.get("Configuration", {})
    legacy = {k: v for k, v in cfg.items() if k in MATERIAL_KEYS or any(
        isinstance(p, re.Pattern) and p.match(k) for p in MATERIAL_KEYS) or k in MATERIAL_VIEWER - {"comment"}}
    if legacy:  # older files keep the fluid's parameters in Configuration
        out[DEFAULT_ID] = ("Configuration", legacy, False)
    for k in [DEFAULT_ID] + sorted(ids_used - {DEFAULT_ID}):
        if k in data:  # older per-id parameter blocks at the top level
            m, new = _material(im, rd.table(data[k], k), k)
            out[k] = (k, {**out.get(k, ("", {}, False))[1], **m}, new)
    for i, m in enumerate(rd.items(data, "Materials")):
        where = f"Materials[{i}]"
        flat, new = _material(im, m, where)
        mid = rd.string(flat, "id", where, DEFAULT_ID)
        out[mid] = (where, flat, new)
    # method blocks anywhere (a material's, the pressure solver's): the newer method numbers
    new = any(v[2] for v in out.values()) or any(k in cfg for k in METHODS.values())
    return {k: (w, m, new) for k, (w, m, _) in out.items()}


def _phase(im: _Import, mid: str, where: str, m: dict, new: bool = False) -> tuple[dict, int | None]:
    """The dcdc phase of a material and its emitter particle cap (``new``: the material has
    method blocks, so the newer viscosity method numbers, without XSPH, apply)."""
    rd = im.rd
    label = f"{where} ({mid})"
    phase = {"density": rd.number(m, "density0", where, 1000.0, positive=True)}
    # SPlisHSPlasH's defaults (FluidModel, Viscosity_Standard): method 1, coefficient 0.01
    method = rd.integer(m, "viscosityMethod", where, DEFAULT_VISCOSITY_METHOD)
    nu = rd.number(m, "viscosity", where, None, nonneg=True)
    if method == DEFAULT_VISCOSITY_METHOD and ("viscosityMethod" not in m or nu is None):
        what = ("its default method (1, standard viscosity)" if "viscosityMethod" not in m
                else "the standard viscosity")
        if nu is None:
            nu = DEFAULT_VISCOSITY
            what += " with its default coefficient"
        im.notes.append(f"{label}: SPlisHSPlasH applies {what}: ν = {nu:g} m²/s")
    if new and method and method not in FORCE_METHODS["viscosityMethod"]:
        im.warn(f"{label}: viscosity method {method} unknown; the phase keeps dcdc's default viscosity")
    elif new and method and nu is not None:  # XSPH is no viscosity method in these files
        phase["viscosity"] = nu
        if method != 1:
            im.warn(f"{label}: viscosity method {method} ({FORCE_METHODS['viscosityMethod'][method]}) "
                    f"mapped to dcdc's explicit viscosity with ν = {nu:g} m²/s")
    elif method and nu is not None:
        name = VISCOSITY.get(method, f"method {method}")
        if method == 2:
            im.warn(f"{label}: XSPH viscosity coefficient {nu:g} (dimensionless) not mapped; the "
                    "phase keeps dcdc's default viscosity")
        else:
            phase["viscosity"] = nu
            if method != 1:
                im.warn(f"{label}: viscosity method {method} ({name}) mapped to dcdc's explicit "
                        f"viscosity with ν = {nu:g} m²/s")
    for key, coef, what in (("surfaceTensionMethod", "surfaceTension", "surface tension"),
                            ("vorticityMethod", "vorticity", "vorticity"),
                            ("dragMethod", "drag", "drag"),
                            ("elasticityMethod", "youngsModulus", "elasticity")):
        k = rd.integer(m, key, where, 0)
        if k:
            c = m.get(coef)
            extra = (" (dcdc has interfacial tension between phases only: "
                     "[solver.interfacial_tension])") if what == "surface tension" else ""
            im.warn(f"{label}: {what} (method {k}" + (f", coefficient {c}" if c is not None else "")
                    + f") not mapped{extra}")
    xsph = rd.number(m, "xsph", where, 0.0, nonneg=True)
    if xsph:
        im.warn(f"{label}: XSPH velocity filter {xsph:g} not mapped (dcdc's is [solver] xsph, "
                "one for all phases)")
    if rd.flag(m, "emitterReuseParticles", where, False):
        im.warn(f"{label}: emitterReuseParticles not mapped (dcdc does not recycle particles that "
                "leave the emitter box)")
    cap = rd.integer(m, "maxEmitterParticles", where, None)
    return phase, cap


def _solver(im: _Import, cfg: dict) -> dict:
    rd, w = im.rd, "Configuration"
    out: dict = {}
    method = rd.integer(cfg, "simulationMethod", w, 4)
    if method == 0:
        out["solver"] = "wcsph"
        e = rd.number(cfg, "exponent", w, None, positive=True)
        if e is not None:
            out["stiffness_exponent"] = e
        if "stiffness" in cfg:
            im.warn(f"Configuration.stiffness {cfg['stiffness']}: not mapped (dcdc's WCSPH sets a speed "
                    "of sound, [solver] sound_speed)")
    elif method != 4:
        im.warn(f"Configuration.simulationMethod {method} ({METHODS.get(method, 'unknown')}): "
                "not mapped; dcdc runs DFSPH")
    cfl_method = rd.integer(cfg, "cflMethod", w, 1)
    if cfl_method == 0:
        im.warn("Configuration.cflMethod 0 (fixed time step"
                + (f" {cfg['timeStepSize']} s" if "timeStepSize" in cfg else "")
                + "): not mapped; dcdc's substeps are CFL-adaptive")
    f = rd.number(cfg, "cflFactor", w, None, positive=True)
    if f is not None:
        out["cfl"] = min(round(0.4 * f, 9), 1.0)
        if 0.4 * f > 1.0:
            im.warn(f"Configuration.cflFactor {f:g}: dcdc's cfl is at most 1 (= cflFactor 2.5)")
    hi = rd.number(cfg, "cflMaxTimeStepSize", w, None, positive=True)
    lo = rd.number(cfg, "cflMinTimeStepSize", w, None, positive=True)
    if hi is not None:
        out["dt_max"] = hi
    if lo is not None:
        if lo <= (hi if hi is not None else 0.005):
            out["dt_min"] = lo
        else:
            im.warn(f"Configuration.cflMinTimeStepSize {lo:g} exceeds the largest step; not mapped")
    n = rd.integer(cfg, "maxIterations", w, None)
    if n is not None:
        if n < 1:
            rd.fail(f"{w}.maxIterations", f"must be >= 1 (got {n})")
        out["max_iterations"] = n
    nv = rd.integer(cfg, "maxIterationsV", w, None)
    if nv is not None and nv != (n if n is not None else 100):
        im.warn(f"Configuration.maxIterationsV {nv}: not mapped (dcdc has one limit for both solves, "
                f"max_iterations = {n if n is not None else 100})")
    for key, name in (("maxError", "density_tolerance"), ("maxErrorV", "divergence_tolerance")):
        e = rd.number(cfg, key, w, None, positive=True)
        if e is not None:
            out[name] = e / 100.0  # percent
    if "enableDivergenceSolver" in cfg:
        out["divergence_solve"] = rd.flag(cfg, "enableDivergenceSolver", w)
    b = rd.integer(cfg, "boundaryHandlingMethod", w, None)
    if b == 0:
        out["boundary"] = "particles"
    elif b == 1:
        im.warn("Configuration.boundaryHandlingMethod 1 (density maps): not mapped; dcdc uses its "
                "volume map")
    for key in ("kernel", "gradKernel"):
        if key in cfg:
            im.warn(f"Configuration.{key} {cfg[key]}: not mapped (dcdc's kernels are fixed)")
    from ...sph import SPHConfig
    try:
        SPHConfig.from_dict(out)
    except DcdcError as e:
        raise DcdcError(f"{im.path.name}: Configuration: {e}") from None
    return out


def _inside_most(mesh, points, weights) -> bool:
    """Whether most of the fluid (``points`` in its items, weighted by their volumes; by
    count when all weigh nothing) lies inside the closed ``mesh``: particle boundaries have
    fluid on both sides, dcdc's walls on one."""
    from ...geometry import mesh as gm
    if not points:
        return False
    inside = gm.MeshDistance(mesh).inside(np.asarray(points, dtype=np.float64))
    w = np.asarray(weights, dtype=np.float64)
    w = w if w.sum() > 0 else np.ones(len(w))
    return bool(w[inside].sum() > w[~inside].sum())


CLIP_POINTS = 200_000  # blocks with more lattice points than this are not checked


def _clip_blocks(im: _Import, fluids: list, boxes: list, placed: list, dim: int, r: float):
    """A box block that reaches into a closed wall (a solid's inside, a container's outside)
    becomes a ``fill`` of its box inside the container that holds it, which leaves out the
    particles in walls (SPlisHSPlasH keeps them and pushes them out); a block mostly in a
    wall is left out (SPlisHSPlasH's particle boundaries hold fluid on both sides of a body,
    dcdc's walls on one). One warning each."""
    from ...geometry import mesh as gm
    if not placed:
        return
    dists = [(name, label, gm.MeshDistance(m), hollow) for name, label, m, hollow in placed]
    sp = 2 * r
    for k, lo, hi in boxes:
        n = np.floor((hi - lo) / sp + 1e-9).astype(int)[:dim]
        if (n < 1).any() or np.prod(n) > CLIP_POINTS:
            continue
        axes = [lo[a] + r + sp * np.arange(n[a]) for a in range(dim)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
        if dim == 2:
            pts = np.c_[pts, np.zeros(len(pts))]
        walled = [(label, md.inside(pts) != hollow) for _, label, md, hollow in dists]
        hit = next((label for label, w in walled if w.any()), None)
        if hit is None:
            continue
        f = fluids[k]
        if np.logical_or.reduce([w for _, w in walled]).mean() > 0.5:
            im.warn(f"{f['name']}: lies mostly in {hit} (SPlisHSPlasH's particle boundaries hold "
                    "fluid on either side of a body, dcdc's walls on one); left out")
            fluids[k] = None
            continue
        mid = 0.5 * (lo + hi)
        box = next((name for name, _, md, hollow in dists
                    if hollow and md.inside(mid[None, :])[0]), None)
        if box is None:
            im.warn(f"{f['name']}: reaches into {hit} and lies in no closed container that dcdc "
                    "could fill instead; kept as a box (the scene will not validate)")
            continue
        fluids[k] = {"phase": f["phase"], "shape": "fill", "inside": box, "min": f["min"],
                     "max": f["max"], "velocity": f["velocity"], "name": f["name"]}
        im.warn(f"{f['name']}: reaches into {hit}; written as a fill of its box inside walls.{box} "
                "without the particles in walls (SPlisHSPlasH keeps them and pushes them out)")


def _front_side(mesh, points) -> bool:
    """Whether most of ``points`` lie in front of an open surface (its normals' side)."""
    from ...geometry import mesh as gm
    if not points:
        return True
    md = gm.MeshDistance(mesh)
    x = np.asarray(points, dtype=np.float64)
    _, c, i = md.closest(x, None)
    return float(md.side(x, c, i).mean()) >= 0


def convert(data: dict, path: Path, output: Path | None, name: str | None = None):
    """The dcdc scene (:class:`~.common.Imported`) of the SPlisHSPlasH scene ``data``."""
    from ...geometry import mesh as gm
    from ..nozzles import box_nozzle_axes, nozzle_points
    im = _Import(path, output)
    rd = im.rd
    blocks, models = rd.items(data, "FluidBlocks"), rd.items(data, "FluidModels")
    emitters_in, bodies = rd.items(data, "Emitters"), rd.items(data, "RigidBodies")
    ids_used = {x.get("id", DEFAULT_ID) for x in blocks + models + emitters_in
                if isinstance(x.get("id", DEFAULT_ID), str)}
    for k in data:
        if k not in SECTIONS | PBD_SECTIONS and k not in ids_used:
            rd.fail("the scene:", f"unknown top-level key {k!r} (not a SPlisHSPlasH section dcdc "
                    "knows, nor the id of a fluid)")
    cfg = _config(im, rd.table(data.get("Configuration", {}), "Configuration"))
    r = rd.number(cfg, "particleRadius", "Configuration", 0.025, positive=True)
    sp = 2 * r
    stop_at = rd.number(cfg, "stopAt", "Configuration", None)
    duration = stop_at if stop_at is not None and stop_at > 0 else 2.0
    fps = rd.number(cfg, "dataExportFPS", "Configuration", None, positive=True)
    solver = _solver(im, cfg)
    particle_walls = solver.get("boundary") == "particles"
    dim = 2 if rd.flag(cfg, "sim2D", "Configuration", False) else 3

    def plane(v, where):
        """``v`` in the scene's dimension: a 2-D scene drops z (with a warning unless 0)."""
        if dim == 3 or v is None:
            return v
        if v[2]:
            im.warn(f"{where}: z component {v[2]:g} dropped (a 2-D scene, Configuration.sim2D)")
        return v[:2]

    # materials -> phases: one per id that a fluid item names, defined or not (a material
    # no fluid uses adds nothing to the scene)
    mats = _materials(im, data, ids_used)
    phases, names, caps = {}, {}, {}
    for mid in [k for k in mats if k in ids_used] + sorted(ids_used - set(mats)):
        where, m, new = mats.get(mid, (f"id {mid!r}", {}, False))
        ph, cap = _phase(im, mid, where, m, new)
        names[mid] = unique(scene_name(mid, "fluid"), phases)
        phases[names[mid]] = ph
        caps[mid] = cap

    refs, weights = [], []  # points inside the fluid (which side of a wall it is on), volumes
    boxes = []  # (index into fluids, 3-D lo, hi) of the blocks
    shifted = []  # blocks whose particles sit off SPlisHSPlasH's (dcdc's lattice)
    fluids = []
    for i, b in enumerate(blocks):
        where = f"FluidBlocks[{i}]"
        im.keys(b, where, BLOCK_KEYS, {"visMesh"}, "fluid block")
        mid = rd.string(b, "id", where, DEFAULT_ID)
        a, e = rd.vec3(b, "start", where), rd.vec3(b, "end", where)
        if a is None or e is None:
            rd.fail(where, "needs 'start' and 'end'")
        s = np.asarray(rd.vec3(b, "scale", where, [1.0, 1.0, 1.0], scalar_ok=True))
        t = np.asarray(rd.vec3(b, "translation", where, [0.0, 0.0, 0.0]))
        p0, p1 = np.asarray(a) * s + t, np.asarray(e) * s + t
        lo, hi = np.minimum(p0, p1), np.maximum(p0, p1)
        if not (hi > lo).all():
            rd.fail(where, f"is empty (start {a}, end {e})")
        dense = rd.integer(b, "denseMode", where, 0)
        n = block_counts(lo, hi, r, dense)
        if (n <= 1).any():
            im.warn(f"{where}: SPlisHSPlasH samples no particles in it ({' x '.join(map(str, n))} "
                    "steps: at most one along an axis); left out")
            continue
        count = int(np.prod(n[:dim]))
        if dense:
            ours = int(np.prod(np.floor((hi - lo)[:dim] / sp + 1e-9)))
            im.warn(f"{where}: denseMode {dense} ({DENSE_MODES.get(dense, 'unknown')}) not mapped: "
                    f"SPlisHSPlasH samples {count} particles, dcdc {ours} on its cubic lattice")
        else:  # a box around as many points of dcdc's lattice, nearest SPlisHSPlasH's
            first = r + sp * np.ceil((lo + sp - r) / sp - 0.5 - 1e-6)  # (odd multiples of r)
            shift = np.abs(first - (lo + sp))[:dim].max()
            if shift > 1e-9 * sp:
                shifted.append(where)
            lo, hi = first - r, first - r + n * sp
        if any(rd.vec3(b, "initialAngularVelocity", where, [0.0, 0.0, 0.0])):
            im.warn(f"{where}: initialAngularVelocity not mapped (dcdc blocks start with one velocity)")
        fluids.append({"phase": names[mid], "shape": "box", "min": lo[:dim].round(9).tolist(),
                       "max": hi[:dim].round(9).tolist(),
                       "velocity": plane(rd.vec3(b, "initialVelocity", where, [0.0, 0.0, 0.0]),
                                         f"{where}.initialVelocity"), "name": where})
        refs.append(((lo + hi) / 2).tolist())
        weights.append(float(np.prod((hi - lo)[:dim])))
        boxes.append((len(fluids) - 1, lo, hi))
    for i, f in enumerate(models):
        where = f"FluidModels[{i}]"
        im.keys(f, where, MODEL_KEYS, {"visMesh"}, "fluid model")
        mid = rd.string(f, "id", where, DEFAULT_ID)
        file = rd.string(f, "particleFile", where)
        if file is None:
            rd.fail(where, "needs a 'particleFile'")
        if not file.lower().endswith(MESH_EXT):
            im.warn(f"{where}: particle file {Path(file).name} not mapped (dcdc fills meshes: "
                    f"{', '.join(MESH_EXT)}); left out")
            continue
        if rd.flag(f, "invert", where, False):
            im.warn(f"{where}: invert (fluid outside the mesh, in its bounding box) not mapped; left out")
            continue
        p = im.file(file, where)
        scale, t, axis, deg = im.placement(f, where)
        m = gm.load_placed_mesh(p, scale, t, axis if deg else None, deg)
        try:
            gm.require_closed(m, "a fluid model is the inside of a closed mesh")
        except DcdcError as e:
            raise DcdcError(f"{path.name}: {where}: {e}") from None
        if rd.integer(f, "denseMode", where, 0):
            im.warn(f"{where}: denseMode {f['denseMode']} not mapped (dcdc fills meshes on its lattice)")
        if any(rd.vec3(f, "initialAngularVelocity", where, [0.0, 0.0, 0.0])):
            im.warn(f"{where}: initialAngularVelocity not mapped")
        fluids.append({"phase": names[mid], "shape": "mesh", "file": toml_path(p, output),
                       **_placed(scale, t, axis, deg),
                       "velocity": plane(rd.vec3(f, "initialVelocity", where, [0.0, 0.0, 0.0]),
                                         f"{where}.initialVelocity"), "name": where})
        refs.append(np.asarray(m.centroid).tolist())
        weights.append(abs(float(m.volume)))

    emitters, emitted = [], {}
    for i, e in enumerate(emitters_in):
        where = f"Emitters[{i}]"
        im.keys(e, where, EMITTER_KEYS, set(), "emitter")
        mid = rd.string(e, "id", where, DEFAULT_ID)
        kind = rd.integer(e, "type", where, 0)
        if kind not in (0, 1):
            rd.fail(f"{where}.type", f"must be 0 (box) or 1 (circle) (got {kind})")
        wn = rd.integer(e, "width", where, 5)
        hn = rd.integer(e, "height", where, 5)
        if wn < 1 or (kind == 0 and hn < 1):
            rd.fail(where, f"needs width (and height) >= 1 particle (got {wn} x {hn})")
        pos = rd.vec3(e, "translation", where, [0.0, 0.0, 0.0])
        _, _, axis, deg = im.placement({k: e[k] for k in ("rotationAxis", "rotationAngle") if k in e}, where)
        if dim == 2:  # SPlisHSPlasH turns 2-D emitters about z whatever the axis
            axis = [0.0, 0.0, 1.0]
        rot = gm.rotation_matrix(axis, deg) if deg else np.eye(3)
        d, up = rot[:, 0], rot[:, 1]  # the jet, the box's height side (its width: the third)
        vel = e.get("velocity", 1.0)
        if isinstance(vel, list):  # older files: a velocity vector (and a direction)
            v = np.asarray(rd.vec3(e, "velocity", where))
            speed = float(np.linalg.norm(v))
            d, up = (v / speed, None) if speed > 0 else (d, up)
        else:
            speed = rd.number(e, "velocity", where, 1.0)
        if "direction" in e:
            dd = np.asarray(rd.vec3(e, "direction", where))
            if not np.linalg.norm(dd) > 0:
                rd.fail(f"{where}.direction", "must be a non-zero vector")
            d, up = dd / np.linalg.norm(dd), None
        if not speed > 0:
            rd.fail(f"{where}.velocity", f"must be > 0 (got {speed:g}): dcdc emitters push fluid out")
        if dim == 2:
            if not np.linalg.norm(d[:2]) > 1e-9:
                rd.fail(where, "jets along z, out of the plane of a 2-D scene (Configuration.sim2D)")
            d = d[:2] / np.linalg.norm(d[:2])
            # SPlisHSPlasH emits in 2-D through a box one particle wide: a segment of
            # height (a circle: width) particles
            n = wn if kind == 1 else hn
            nozzle, per_layer = {"shape": "box", "height": round(n * sp, 9)}, n
        elif kind == 1:
            radius = wn * r  # SPlisHSPlasH: radius 0.5 · width · 2r
            g = (np.arange(wn) - 0.5 * (wn - 1)) * sp
            per_layer = int((g[:, None] ** 2 + g[None, :] ** 2 <= radius ** 2 + 1e-12).sum())
            nozzle = {"radius": round(radius, 9)}
        else:  # width particles along the rotation's third column, height along its second
            nozzle = {"shape": "box", "width": round(wn * sp, 9), "height": round(hn * sp, 9)}
            if up is not None and abs(float(box_nozzle_axes(d)[0] @ up)) < 1 - 1e-9:
                nozzle["up"] = up.round(12).tolist()  # not dcdc's default height side
            per_layer = wn * hn
        start = rd.number(e, "emitStartTime", where, 0.0, nonneg=True)
        end = rd.number(e, "emitEndTime", where, None)
        stop = min(end, duration) if end is not None else duration
        if stop <= start:
            im.warn(f"{where}: emits only after the run ({start:g} s, duration {duration:g} s); left out")
            continue
        em = {"phase": names[mid], **({"shape": nozzle.pop("shape")} if "shape" in nozzle else {}),
              "position": pos[:dim], "direction": d.round(12).tolist(), "speed": speed, **nozzle,
              "start": start, "stop": round(stop, 9)}
        eps = rd.number(e, "emitsPerSecond", where, None, positive=True)
        if eps is not None:
            em["rate"] = per_layer * eps
        if caps.get(mid) is not None:  # maxEmitterParticles: the phase's emitters share it
            _, _, births = nozzle_points({**em, "rate": em.get("rate")}, dim, sp)
            left = caps[mid] - emitted.get(mid, 0)
            if left < len(births):
                layers = np.unique(births)  # more than one: a single layer fits or is refused
                n_layer = len(births) // len(layers)
                k = left // n_layer
                if k == 0:
                    im.warn(f"{where}: its material's maxEmitterParticles ({caps[mid]}) is used up; left out")
                    continue
                em["stop"] = round(float(layers[k - 1] + 0.5 * (layers[1] - layers[0])), 9)
                births = births[:k * n_layer]
                if left > k * n_layer:
                    im.warn(f"{where}: SPlisHSPlasH emits {left} particles (maxEmitterParticles "
                            f"{caps[mid]}), its last layer {left - k * n_layer} of {n_layer}; dcdc "
                            f"emits whole layers: {k * n_layer}")
            emitted[mid] = emitted.get(mid, 0) + len(births)
        size = emitter_housing(kind, wn, hn, r, particle_walls)
        im.warn(f"{where}: SPlisHSPlasH's static emitter housing ({'box' if kind == 0 else 'cylinder'} "
                f"{' x '.join(f'{v:.3g}' for v in size[:dim])} m, along the jet first, open towards it) "
                "not mapped; it stays in the flow after the emitter stops")
        emitters.append(em)
        refs.append(pos)
        weights.append(0.0)

    walls, placed = {}, []
    for i, b in enumerate(bodies):
        where = f"RigidBodies[{i}]"
        im.keys(b, where, BODY_KEYS, BODY_VIEWER, "rigid body")
        file = rd.string(b, "geometryFile", where)
        if file is None:
            im.warn(f"{where}: no geometryFile (particle samplings of walls are not read); left out")
            continue
        p = im.file(file, where)
        scale, t, axis, deg = im.placement(b, where)
        m = gm.load_placed_mesh(p, scale, t, axis if deg else None, deg)
        label = f"{where} ({p.name})"
        if rd.flag(b, "isDynamic", where, False):
            im.warn(f"{label}: a dynamic rigid body, imported as a static wall")
        entry = {"shape": "mesh", "file": toml_path(p, output), **_placed(scale, t, axis, deg)}
        thick = rd.number(b, "mapThickness", where, 0.0, nonneg=True)
        if m.metadata["dcdc_closed"]:
            if "mapInvert" in b and not particle_walls:
                entry["hollow"] = rd.flag(b, "mapInvert", where)
            else:  # particle boundaries have no side: the fluid's side is the inside
                entry["hollow"] = _inside_most(m, refs, weights)
            if thick:
                im.warn(f"{label}: mapThickness {thick:g} not mapped (dcdc's walls are "
                        "wall_thickness deep)")
        else:
            entry["thickness"] = max(4 * r, thick)
            entry["invert_normals"] = not _front_side(m, refs)  # the shell away from the fluid
        wname = unique(scene_name(p.stem, "wall"), walls)
        walls[wname] = entry
        if m.metadata["dcdc_closed"]:
            placed.append((wname, label, m, entry["hollow"]))
    _clip_blocks(im, fluids, boxes, placed, dim, r)
    fluids = [f for f in fluids if f is not None]

    for i, f in enumerate(rd.items(data, "AnimationFields")):
        im.keys(f, f"AnimationFields[{i}]", FIELD_KEYS, set(), "animation field")
        im.warn(f"AnimationFields[{i}] ({f.get('particleField', 'velocity')}): animation fields are "
                "not mapped")
    if "Simulation" in data:
        im.warn("Simulation: PositionBasedDynamics settings (dynamic bodies) not mapped")
    for k in sorted(set(data) & PBD_SECTIONS):
        im.warn(f"{k}: PositionBasedDynamics models and joints are not mapped")
    if im.viewer:
        im.warnings.append("viewer and export settings not used: " + ", ".join(im.viewer))
    if not (walls or fluids or emitters):
        raise DcdcError(f"{path.name}: the scene has no fluid blocks, fluid models, emitters or "
                        "rigid bodies")
    notes = [f"duration {duration:g} s" + (" (Configuration.stopAt)" if stop_at and stop_at > 0
                                           else " (the scene sets no stopAt)")]
    notes += im.notes
    if shifted:
        notes.append(f"{', '.join(shifted)}: as many particles as SPlisHSPlasH samples, on dcdc's "
                     "lattice (odd multiples of r): up to r nearer start than SPlisHSPlasH's")
    if sum(bool(p.get("viscosity")) for p in phases.values()) > 1:
        notes.append("viscosity: SPlisHSPlasH's standard viscosity acts between particles of the "
                     "same fluid only, dcdc's between phases too")
    if dim == 2:
        notes.append("a 2-D scene (Configuration.sim2D): the plane z = 0, where meshes are sectioned")
    # no [domain]: dcdc derives the box around walls and fluid (SPlisHSPlasH has no domain)
    if not any(w.get("hollow") for w in walls.values()):
        solver["on_escape"] = "remove"
        notes.append("no closed container: fluid that leaves the box around walls and fluid is "
                     "removed ([solver] on_escape = \"remove\")")
    scene = {
        "name": scene_name(name or path.stem),
        "description": f"imported from the SPlisHSPlasH scene {path.name}",
        "dim": dim, "radius": r, "duration": duration,
    }
    if fps is not None:
        scene["frame_dt"] = round(1.0 / fps, 9)
    g = plane(rd.vec3(cfg, "gravitation", "Configuration", None), "Configuration.gravitation")
    if g is not None:
        scene["gravity"] = g
    scene["phases"] = phases
    if walls:
        scene["walls"] = walls
    if fluids:
        scene["fluid"] = fluids
    if emitters:
        scene["emitter"] = emitters
    if solver:
        scene["solver"] = solver
    return finish(scene, im.warnings, FMT, path, output, notes)
