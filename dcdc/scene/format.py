"""Scene files: TOML text -> validated scene -> :class:`~dcdc.particles.ParticleSystem`.

The format is documented in ``docs/scenes.md``. Every key is checked against a schema:
unknown keys, wrong types and out-of-range values raise :class:`DcdcError` naming the
dotted field and, where it can be found, its line ("phases.oil.density must be > 0
(line 12)"). Realising a scene reports (never repairs) overlapping fluid blocks, fluid
inside walls, fluid outside the domain and missing mesh files.

A scene without ``[domain]`` gets the axis-aligned box around its walls, fluid blocks and
emitters (:func:`derive_domain`, per variant; ``meta["scene_domain"]`` of the realised
system holds it); a wall without such a box (terrain) asks for ``[domain]``.

Meshes (OBJ, STL, ... scaled per axis, rotated, translated) are walls (closed solids,
containers or shells), fluid blocks (``shape = "mesh"``: a closed mesh's inside on the
global lattice) and emitters (``shape = "mesh"``: that fluid released repeatedly).
Nozzle emitters are round (``shape = "nozzle"``) or rectangular (``shape = "box"``).

A 3-D scene also yields its 2-D cross-section (``dim=2``): every vector drops its z
component, solids of revolution become their section through the axis, terrain is cut at
``slice_z`` and meshes are sectioned by the plane z = ``slice_z``. ``resolution`` S
multiplies every length by S at a fixed particle radius, so the fluid count scales ~S^dim.
"""
from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as a package
    import tomli as tomllib

from ..errors import DcdcError
from ..particles import DEFAULT_RADIUS, FRAME_DT, ParticleSystem, Phase

# ------------------------------------------------------------------ schema
# kinds: str, int, seed (0 .. 2^63 - 1), bool, float, pos (>0), nonneg (>=0), L (length > 0),
# L0 (length >= 0), vec (dim floats), vecL (dim floats, a position/length), vec3 / vec3L
# (3 floats / lengths, whatever dim), scale (a factor > 0 or one per axis), color, profileL
# ([[r, y], ...] lengths), pairL ([a, b] lengths), pair ([a, b] floats), table (free-form)
REQ = object()  # marks a required key

TOP = {
    "name": ("str", REQ), "description": ("str", ""), "dim": ("dim", REQ),
    "radius": ("pos", DEFAULT_RADIUS), "duration": ("pos", 2.0), "frame_dt": ("pos", FRAME_DT),
    "gravity": ("vec", None), "seed": ("seed", 0), "wall_thickness": ("L", None),
    "domain": ("section", None), "phases": ("section", REQ), "walls": ("section", {}),
    "fluid": ("list", []), "emitter": ("list", []), "solver": ("table", {}),
}
DOMAIN = {"min": ("vecL", REQ), "max": ("vecL", REQ)}
PHASE = {"density": ("pos", REQ), "viscosity": ("nonneg", 1e-6), "color": ("color", None)}
WALL_COMMON = {"shape": ("str", REQ)}
# a mesh file placed in the scene: scaled, rotated about the origin, translated (walls,
# fluid and emitters of shape "mesh"); slice_z: the plane of the 2-D cross-section
MESH_PLACE = {"file": ("str", REQ), "scale": ("scale", 1.0), "translate": ("vec3L", None),
              "rotation_axis": ("vec3", None), "rotation_degrees": ("float", 0.0),
              "slice_z": ("float", 0.0)}
WALL_SHAPES = {
    "box": {"min": ("vecL", REQ), "max": ("vecL", REQ), "hollow": ("bool", False),
            "open_top": ("bool", True)},
    "sphere": {"center": ("vecL", REQ), "radius": ("L", REQ)},
    "cylinder": {"center": ("vecL", REQ), "radius": ("L", REQ), "height": ("L", REQ),
                 "axis": ("int", 1)},
    "bowl": {"center": ("vecL", REQ), "radius": ("L", REQ), "thickness": ("L", None)},
    "glass": {"center": ("vecL", REQ), "bowl": ("profileL", REQ), "stem": ("L0", REQ),
              "foot": ("L", REQ), "thickness": ("L", None)},
    "hourglass": {"center": ("vecL", REQ), "radius": ("L", REQ), "height": ("L", REQ),
                  "neck": ("L", REQ), "neck_height": ("L", None), "thickness": ("L", None)},
    "terrain": {"x": ("pairL", REQ), "z": ("pairL", REQ), "base": ("float", REQ),
                "slope": ("float", 0.1), "seed": ("seed", None), "roughness": ("L0", 0.05),
                "channels": ("int", 2), "channel_depth": ("L0", 0.15), "channel_width": ("L", 0.3),
                "depressions": ("int", 3), "depression_depth": ("L0", 0.15),
                "depression_radius": ("L", 0.3), "slice_z": ("float", None)},
    "mesh": {**MESH_PLACE, "hollow": ("bool", False), "thickness": ("L", None),
             "invert_normals": ("bool", False)},
}
# a block has one phase, or with ``phases`` (and optional ``fractions``) a random phase per
# particle (an emulsion), drawn from the scene's seed
FLUID_COMMON = {"phase": ("str", None), "phases": ("list", None), "fractions": ("list", None),
                "shape": ("str", REQ), "velocity": ("vec", None), "name": ("str", None)}
FLUID_SHAPES = {
    "box": {"min": ("vecL", REQ), "max": ("vecL", REQ), "top_wave": ("pair", None),
            "bottom_wave": ("pair", None)},
    "sphere": {"center": ("vecL", REQ), "radius": ("L", REQ)},
    "cylinder": {"center": ("vecL", REQ), "radius": ("L", REQ), "height": ("L", REQ),
                 "axis": ("int", 1)},
    "fill": {"inside": ("str", REQ), "min": ("vecL", None), "max": ("vecL", None),
             "clearance": ("L0", None), "top_wave": ("pair", None), "bottom_wave": ("pair", None)},
    "mesh": {**MESH_PLACE, "clearance": ("L0", None)},
}
EMITTER = {"shape": ("str", "nozzle"), "phase": ("str", REQ), "position": ("vecL", REQ),
           "direction": ("vec", REQ), "speed": ("pos", REQ), "radius": ("L", None),
           "rate": ("pos", None), "start": ("nonneg", 0.0), "stop": ("pos", REQ)}
# a rectangular nozzle: width x height across the jet, the height side along ``up`` (3-D);
# in 2-D a segment of length height
EMITTER_BOX = {**{k: v for k, v in EMITTER.items() if k != "radius"}, "shape": ("str", REQ),
               "width": ("L", None), "height": ("L", REQ), "up": ("vec", None)}
# the fluid inside a closed mesh released whole at start, start + interval, ... < stop
EMITTER_MESH = {"shape": ("str", REQ), "phase": ("str", REQ), **MESH_PLACE,
                "velocity": ("vec", None), "start": ("nonneg", 0.0), "stop": ("pos", REQ),
                "interval": ("pos", REQ)}
EMITTER_SHAPES = {"nozzle": EMITTER, "box": EMITTER_BOX, "mesh": EMITTER_MESH}
NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_\-]*$")
# a scene's name becomes file names (NAME_3d.failed.json, its temporary .NAME_3d.h5.tmp-PID):
# with this limit they fit the 255 bytes a file name may have
NAME_MAX = 200
SEED_MAX = 2**63 - 1  # seeds are stored as int64 in datasets
DEFAULT_COLORS = [(0.85, 0.2, 0.15), (0.2, 0.7, 0.25), (0.15, 0.35, 0.85), (0.95, 0.75, 0.1),
                  (0.6, 0.3, 0.75), (0.1, 0.7, 0.75), (0.9, 0.45, 0.1), (0.5, 0.5, 0.5)]


def _find_line(text: str, path: str) -> int | None:
    """Best-effort line number (1-based) of a dotted field in TOML text."""
    if not text:
        return None
    parts = path.split(".")
    lines = text.splitlines()
    # array-of-tables element: fluid[2].min
    m = re.match(r"^(\w+)\[(\d+)\]$", parts[0])
    start, end = 0, len(lines)
    if m:
        hdr = re.compile(r"^\s*\[\[\s*" + re.escape(m.group(1)) + r"\s*\]\]")
        hits = [i for i, ln in enumerate(lines) if hdr.match(ln)]
        k = int(m.group(2))
        if k >= len(hits):
            return None
        start = hits[k]
        if len(parts) == 1:
            return start + 1
        key = parts[-1]
    else:
        # longest table header that is a prefix of the path
        key = parts[-1]
        for n in range(len(parts), 0, -1):
            pat = re.compile(r"^\s*\[\s*" + r"\s*\.\s*".join(re.escape(p) for p in parts[:n])
                             + r"\s*\]\s*(#.*)?$")
            hits = [i for i, ln in enumerate(lines) if pat.match(ln)]
            if hits:
                if n == len(parts):
                    return hits[0] + 1
                start = hits[0]
                key = parts[n]
                break
        else:
            start = 0
    for i in range(start + (1 if start or m else 0), end):
        ln = lines[i]
        if i > start and re.match(r"^\s*\[", ln) and (m or start):
            break
        if re.match(r"^\s*" + re.escape(key) + r"\s*=", ln) or \
                re.search(r"[{,]\s*" + re.escape(key) + r"\s*=", ln):
            return i + 1
    return None


class _Checker:
    def __init__(self, text: str, source: str):
        self.text = text
        self.source = source

    def fail(self, path: str, msg: str):
        line = _find_line(self.text, path)
        where = f" (line {line})" if line else ""
        raise DcdcError(f"{self.source}: {path} {msg}{where}")

    def value(self, path, kind, v, dim):
        def num(x):
            return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)

        def vec(n):
            if not (isinstance(v, list) and len(v) == n and all(num(c) for c in v)):
                self.fail(path, f"must be a list of {n} numbers (got {v!r})")
            return [float(c) for c in v]
        if kind == "str":
            if not isinstance(v, str):
                self.fail(path, f"must be a string (got {v!r})")
            return v
        if kind in ("int", "seed"):
            if not isinstance(v, int) or isinstance(v, bool):
                self.fail(path, f"must be an integer (got {v!r})")
            if kind == "seed" and not 0 <= v <= SEED_MAX:
                self.fail(path, f"must be an integer from 0 to 2^63 - 1 (got {v})")
            if abs(v) > SEED_MAX:
                self.fail(path, f"must be an integer of at most 2^63 - 1 in size (got {v})")
            return v
        if kind == "dim":
            if not isinstance(v, int) or isinstance(v, bool) or v not in (2, 3):
                self.fail(path, f"must be 2 or 3 (got {v!r})")
            return v
        if kind == "bool":
            if not isinstance(v, bool):
                self.fail(path, f"must be true or false (got {v!r})")
            return v
        if kind in ("float", "pos", "nonneg", "L", "L0"):
            if not num(v):
                self.fail(path, f"must be a number (got {v!r})")
            if kind in ("pos", "L") and not v > 0:
                self.fail(path, f"must be > 0 (got {v})")
            if kind in ("nonneg", "L0") and not v >= 0:
                self.fail(path, f"must be >= 0 (got {v})")
            return float(v)
        if kind in ("vec", "vecL"):
            return vec(dim)
        if kind in ("vec3", "vec3L"):
            return vec(3)
        if kind == "scale":
            if num(v):
                if not v > 0:
                    self.fail(path, f"must be > 0 (got {v})")
                return float(v)
            if not (isinstance(v, list) and len(v) == 3 and all(num(c) and c > 0 for c in v)):
                self.fail(path, f"must be a number > 0 or a list of 3 numbers > 0 (got {v!r})")
            return [float(c) for c in v]
        if kind in ("pair", "pairL"):
            return vec(2)
        if kind == "color":
            if isinstance(v, str) and re.match(r"^#[0-9a-fA-F]{6}$", v):
                return [int(v[i:i + 2], 16) / 255 for i in (1, 3, 5)]
            if isinstance(v, list) and len(v) == 3 and all(num(c) and 0 <= c <= 1 for c in v):
                return [float(c) for c in v]
            self.fail(path, f"must be \"#rrggbb\" or [r, g, b] in 0..1 (got {v!r})")
        if kind == "profileL":
            if not (isinstance(v, list) and len(v) >= 2 and all(
                    isinstance(p, list) and len(p) == 2 and all(num(c) for c in p) for p in v)):
                self.fail(path, f"must be a list of at least two [radius, height] pairs")
            if any(p[0] < 0 for p in v):
                self.fail(path, "radii must be >= 0")
            return [[float(a), float(b)] for a, b in v]
        if kind == "table":
            if not isinstance(v, dict):
                self.fail(path, "must be a table")
            return copy.deepcopy(v)
        raise AssertionError(kind)

    def table(self, path, d, spec, dim):
        if not isinstance(d, dict):
            self.fail(path, "must be a table")
        out = {}
        for k, v in d.items():
            if k not in spec:
                self.fail(f"{path}.{k}" if path else k,
                          f"is not a known key (allowed: {', '.join(sorted(spec))})")
        for k, (kind, default) in spec.items():
            p = f"{path}.{k}" if path else k
            if k in d:
                if kind in ("section", "list"):
                    out[k] = d[k]
                else:
                    out[k] = self.value(p, kind, d[k], dim)
            elif default is REQ:
                self.fail(p, "is required")
            else:
                out[k] = copy.deepcopy(default)
        return out


def validate(raw: dict, text: str = "", source: str = "scene") -> dict:
    """Check a parsed scene table against the schema; return it with defaults filled in."""
    ck = _Checker(text, source)
    dim = raw.get("dim")
    if not isinstance(dim, int) or isinstance(dim, bool) or dim not in (2, 3):
        ck.fail("dim", f"must be 2 or 3 (got {dim!r})" if "dim" in raw else "is required")
    s = ck.table("", raw, TOP, dim)
    if not NAME_RE.match(s["name"]):
        ck.fail("name", "must be letters, digits, _ or - (starting with a letter)")
    if len(s["name"]) > NAME_MAX:
        ck.fail("name", f"is {len(s['name'])} characters long; at most {NAME_MAX} (file names "
                        f"are made from it)")
    s["gravity"] = s["gravity"] if s["gravity"] is not None else [0.0, -9.81, 0.0][:dim]
    if s["domain"] is not None:  # else derived from walls and fluid (derive_domain)
        s["domain"] = ck.table("domain", s["domain"], DOMAIN, dim)
        if not all(b > a for a, b in zip(s["domain"]["min"], s["domain"]["max"])):
            ck.fail("domain.max", "must exceed domain.min in every axis")
    if not isinstance(s["phases"], dict) or not s["phases"]:
        ck.fail("phases", "must define at least one phase ([phases.NAME] with a density)")
    phases = {}
    for i, (name, p) in enumerate(s["phases"].items()):
        if not NAME_RE.match(name):
            ck.fail(f"phases.{name}", "name must be letters, digits, _ or -")
        phases[name] = ck.table(f"phases.{name}", p, PHASE, dim)
        if phases[name]["color"] is None:
            phases[name]["color"] = list(DEFAULT_COLORS[i % len(DEFAULT_COLORS)])
    s["phases"] = phases
    walls = {}
    if not isinstance(s["walls"], dict):
        ck.fail("walls", "must be a table of named walls ([walls.NAME] with a shape)")
    for name, w in s["walls"].items():
        p = f"walls.{name}"
        if not isinstance(w, dict):
            ck.fail(p, "must be a table")
        shape = w.get("shape")
        if shape not in WALL_SHAPES:
            ck.fail(f"{p}.shape", f"must be one of {', '.join(WALL_SHAPES)} (got {shape!r})")
        walls[name] = ck.table(p, w, {**WALL_COMMON, **WALL_SHAPES[shape]}, dim)
        if shape == "box" and not all(b > a for a, b in zip(walls[name]["min"], walls[name]["max"])):
            ck.fail(f"{p}.max", "must exceed min in every axis")
        if shape in ("cylinder",) and walls[name]["axis"] not in range(dim):
            ck.fail(f"{p}.axis", f"must be 0..{dim - 1}")
        if shape == "hourglass" and walls[name]["neck"] >= walls[name]["radius"]:
            ck.fail(f"{p}.neck", "must be smaller than radius")
        if shape == "mesh":
            _check_rotation(ck, p, walls[name])
        if shape == "mesh" and walls[name]["thickness"] is not None and walls[name]["hollow"]:
            ck.fail(f"{p}.hollow", "does not apply to a shell (thickness): its side is behind "
                    "the faces, or in front of them with invert_normals = true")
        if shape == "mesh" and walls[name]["thickness"] is None and walls[name]["invert_normals"]:
            ck.fail(f"{p}.invert_normals", "applies to a shell (give thickness); a closed mesh "
                    "is oriented automatically and hollow = true puts the fluid inside it")
        if shape == "terrain":
            for k in ("channels", "depressions"):
                if not 0 <= walls[name][k] <= 16:
                    ck.fail(f"{p}.{k}", "must be 0..16")
    s["walls"] = walls
    if not isinstance(s["fluid"], list):
        ck.fail("fluid", "must be an array of tables ([[fluid]])")
    fluids = []
    for i, f in enumerate(s["fluid"]):
        p = f"fluid[{i}]"
        if not isinstance(f, dict):
            ck.fail(p, "must be a table")
        shape = f.get("shape")
        if shape not in FLUID_SHAPES:
            ck.fail(f"{p}.shape", f"must be one of {', '.join(FLUID_SHAPES)} (got {shape!r})")
        fb = ck.table(p, f, {**FLUID_COMMON, **FLUID_SHAPES[shape]}, dim)
        _check_fluid_phases(ck, p, fb, phases)
        if fb["velocity"] is None:
            fb["velocity"] = [0.0] * dim
        if shape == "fill" and fb["inside"] not in walls:
            ck.fail(f"{p}.inside", f"names no wall (walls: {', '.join(walls) or 'none'})")
        if shape == "box" and not all(b > a for a, b in zip(fb["min"], fb["max"])):
            ck.fail(f"{p}.max", "must exceed min in every axis")
        if shape == "mesh":
            _check_rotation(ck, p, fb)
        fluids.append(fb)
    s["fluid"] = fluids
    if not isinstance(s["emitter"], list):
        ck.fail("emitter", "must be an array of tables ([[emitter]])")
    ems = []
    for i, e in enumerate(s["emitter"]):
        p = f"emitter[{i}]"
        if not isinstance(e, dict):
            ck.fail(p, "must be a table")
        shape = e.get("shape", "nozzle")
        if shape not in EMITTER_SHAPES:
            ck.fail(f"{p}.shape", f"must be one of {', '.join(EMITTER_SHAPES)} (got {shape!r})")
        em = ck.table(p, e, EMITTER_SHAPES[shape], dim)
        if em["phase"] not in phases:
            ck.fail(f"{p}.phase", f"names no phase (phases: {', '.join(phases)})")
        if shape in ("nozzle", "box") and np.linalg.norm(em["direction"]) == 0:
            ck.fail(f"{p}.direction", "must be a non-zero vector")
        if shape == "box":
            _check_box_nozzle(ck, p, em, dim)
        if shape == "mesh":
            _check_rotation(ck, p, em)
            if em["velocity"] is None:
                em["velocity"] = [0.0] * dim
        if em["stop"] <= em["start"]:
            ck.fail(f"{p}.stop", "must be later than start")
        ems.append(em)
    s["emitter"] = ems
    if not fluids and not ems:
        ck.fail("fluid", "is empty: a scene needs at least one [[fluid]] block or [[emitter]]")
    return s


def _check_fluid_phases(ck: _Checker, p: str, fb: dict, phases: dict) -> None:
    """A block's ``phase``, or its ``phases`` (an emulsion: distinct phase names) with
    optional ``fractions`` (one number > 0 per phase, normalised here; default equal)."""
    if (fb["phase"] is None) == (fb["phases"] is None):
        ck.fail(p, "needs phase = NAME or phases = [NAME, ...] (one of them)")
    if fb["phase"] is not None:
        if fb["fractions"] is not None:
            ck.fail(f"{p}.fractions", "applies to phases = [...] only")
        if fb["phase"] not in phases:
            ck.fail(f"{p}.phase", f"names no phase (phases: {', '.join(phases)})")
        return
    ps = fb["phases"]
    if not (isinstance(ps, list) and ps and all(isinstance(n, str) for n in ps)):
        ck.fail(f"{p}.phases", f"must be a list of phase names (got {ps!r})")
    for n in ps:
        if n not in phases:
            ck.fail(f"{p}.phases", f"{n!r} names no phase (phases: {', '.join(phases)})")
    if len(set(ps)) != len(ps):
        ck.fail(f"{p}.phases", "names a phase twice")
    fr = fb["fractions"]
    if fr is None:
        fr = [1.0] * len(ps)
    if not (isinstance(fr, list) and len(fr) == len(ps) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
            for v in fr)):
        ck.fail(f"{p}.fractions", f"must be {len(ps)} numbers > 0, one per phase (got {fr!r})")
    fb["fractions"] = [float(v) / sum(fr) for v in fr]


def _block_phases(f: dict, i: int, n: int, names: list, seed: int) -> np.ndarray:
    """Phase index of each of the ``n`` particles of fluid block ``i``: its phase, or for
    ``phases`` a random one per particle (drawn with ``fractions`` from [seed, i])."""
    if f["phases"] is None:
        return np.full(n, names.index(f["phase"]))
    idx = np.array([names.index(p) for p in f["phases"]])
    rng = np.random.default_rng([int(seed), 0xE5, i])
    return idx[rng.choice(len(idx), size=n, p=f["fractions"])]


def _check_box_nozzle(ck: _Checker, p: str, e: dict, dim: int) -> None:
    """A box nozzle: width (3-D only, required there) and an ``up`` not along the jet."""
    flat = "applies to 3-D scenes (a 2-D box nozzle is a segment of length height across the jet)"
    if dim == 2:
        for k in ("width", "up"):
            if e[k] is not None:
                ck.fail(f"{p}.{k}", flat)
        return
    if e["width"] is None:
        ck.fail(f"{p}.width", "is required (a 3-D box nozzle is width x height)")
    up, d = e["up"], np.asarray(e["direction"])
    if up is not None and np.linalg.norm(np.cross(up, d)) <= 1e-9 * np.linalg.norm(up) * np.linalg.norm(d):
        ck.fail(f"{p}.up", "must be a vector not along the direction (it orients the height side)")


def _check_rotation(ck: _Checker, p: str, d: dict) -> None:
    if d["rotation_degrees"] and (d["rotation_axis"] is None or not any(d["rotation_axis"])):
        ck.fail(f"{p}.rotation_axis", "must be a non-zero vector when rotation_degrees is set")


# ------------------------------------------------------------------ variants
def _transform(s: dict, dim: int, scale: float) -> dict:
    """Cross-section (3-D -> 2-D) and length scaling of a validated scene."""
    s = copy.deepcopy(s)
    src = s["dim"]
    if dim not in (2, 3):
        raise DcdcError(f"dim must be 2 or 3 (got {dim})")
    if dim > src:
        raise DcdcError(f"scene {s['name']} is {src}-D; it has no {dim}-D variant")
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
        raise DcdcError(f"resolution must be a finite number > 0 (got {scale})")

    def conv(d, spec):
        for k, (kind, _) in spec.items():
            v = d.get(k)
            if v is None:
                continue
            if kind in ("vec", "vecL"):
                v = v[:dim]
            if kind in ("vecL", "vec3L", "pairL"):
                v = [c * scale for c in v]
            elif kind in ("L", "L0"):
                v = v * scale
            elif kind == "profileL":
                v = [[a * scale, b * scale] for a, b in v]
            d[k] = v
    conv(s, {k: v for k, v in TOP.items() if v[0] not in ("section", "list", "table")})
    if s["domain"] is not None:
        conv(s["domain"], DOMAIN)
    for w in s["walls"].values():
        if w["shape"] == "terrain":
            w["base"] *= scale
            if w["slice_z"] is not None:
                w["slice_z"] *= scale
        if w["shape"] == "mesh":
            _scale_mesh(w, scale)
        conv(w, WALL_SHAPES[w["shape"]])
    for f in s["fluid"]:
        if f["shape"] == "mesh":
            _scale_mesh(f, scale)
        conv(f, {**FLUID_COMMON, **FLUID_SHAPES[f["shape"]]})
        for k in ("top_wave", "bottom_wave"):
            if f.get(k) is not None:
                f[k] = [c * scale for c in f[k]]
    for e in s["emitter"]:
        if e["shape"] == "mesh":
            _scale_mesh(e, scale)
        conv(e, EMITTER_SHAPES[e["shape"]])
    s["dim"] = dim
    return s


def _scale_mesh(d: dict, scale: float) -> None:
    """A placed mesh at resolution ``scale``: its scale and section plane (the translation
    is a length and scaled with the others)."""
    d["slice_z"] *= scale
    d["scale"] = [c * scale for c in d["scale"]] if isinstance(d["scale"], list) else d["scale"] * scale


# ------------------------------------------------------------------ realisation
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


def nozzle_ticks(length: float, spacing: float) -> np.ndarray:
    """Offsets of the points across one side of a box nozzle: floor(length / spacing) of
    them (at least one), ``spacing`` apart and centred, as in a box block of that size."""
    n = max(1, int(math.floor(length / spacing + 1e-9)))
    return (np.arange(n) - 0.5 * (n - 1)) * spacing


def box_nozzle_axes(direction, up=None):
    """(height axis, width axis) of a 3-D box nozzle jetting along ``direction``: ``up``
    (default y, or x for a vertical jet) made normal to the jet, and direction × height."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    if up is None:
        up = [1.0, 0.0, 0.0] if abs(d[1]) > 1 - 1e-6 else [0.0, 1.0, 0.0]
    h = np.asarray(up, dtype=np.float64)
    h = h - (h @ d) * d
    h /= np.linalg.norm(h)
    return h, np.cross(d, h)


def _nozzle_layer(e: dict, dim: int, spacing: float) -> np.ndarray:
    """One layer of a nozzle's particles around ``position``, across the jet: a round
    nozzle's disc (a segment in 2-D) of points k·spacing from the centre within
    ``radius``; a box nozzle's width × height grid (in 2-D: the segment of its height)."""
    d = np.asarray(e["direction"], dtype=np.float64)
    d /= np.linalg.norm(d)
    if e.get("shape", "nozzle") == "box":
        if dim == 2:
            disc = nozzle_ticks(e["height"], spacing)[:, None] * np.array([-d[1], d[0]])[None]
        else:
            h, w = box_nozzle_axes(d, e.get("up"))
            a, b = np.meshgrid(nozzle_ticks(e["width"], spacing), nozzle_ticks(e["height"], spacing),
                               indexing="ij")
            disc = a.reshape(-1, 1) * w[None] + b.reshape(-1, 1) * h[None]
        return np.asarray(e["position"]) + disc
    r = e.get("radius") if e.get("radius") is not None else 2 * spacing
    # orthonormal basis of the plane normal to d
    a = np.eye(dim)[np.argmin(np.abs(d))]
    u = a - (a @ d) * d
    u /= np.linalg.norm(u)
    n = int(np.floor(r / spacing + 1e-9))
    ks = np.arange(-n, n + 1) * spacing
    if dim == 2:
        disc = ks[:, None] * u[None]
    else:
        w = np.cross(d, u)
        g = np.stack(np.meshgrid(ks, ks, indexing="ij"), -1).reshape(-1, 2)
        g = g[np.linalg.norm(g, axis=1) <= r + 1e-9]
        disc = g[:, :1] * u[None] + g[:, 1:] * w[None]
    return np.asarray(e["position"]) + disc


def _emitter_points(e: dict, dim: int, spacing: float):
    """Nozzle cross-section points (:func:`_nozzle_layer`) repeated in layers: positions,
    velocities and birth times."""
    d = np.asarray(e["direction"], dtype=np.float64)
    d /= np.linalg.norm(d)
    pos = _nozzle_layer(e, dim, spacing)
    per_layer = len(pos)
    interval = spacing / e["speed"] if e["rate"] is None else per_layer / e["rate"]
    n_layers = int(np.ceil((e["stop"] - e["start"]) / interval - 1e-9))
    births = e["start"] + interval * np.arange(n_layers)
    x = np.tile(pos, (n_layers, 1))
    b = np.repeat(births, per_layer)
    v = np.tile(e["speed"] * d, (len(x), 1))
    return x, v, b


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
            x = _nozzle_layer(e, dim, sp)
            boxes.append((x.min(0) - sp / 2, x.max(0) + sp / 2))
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    flat = [a for a, (l, h) in enumerate(zip(lo, hi)) if not h > l]
    if flat:
        raise DcdcError(f"{src}: the box around the walls and fluid is flat along {'xyz'[flat[0]]}; "
                        "give the scene a [domain] with min and max")
    return {"min": [float(v) for v in lo], "max": [float(v) for v in hi]}


@dataclass
class Scene:
    """A validated scene. ``data`` holds every field with defaults filled in."""

    data: dict
    text: str = ""
    path: Path | None = None
    builtin: bool = False
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        return self.data["name"]

    @property
    def dim(self) -> int:
        return self.data["dim"]

    @property
    def duration(self) -> float:
        return self.data["duration"]

    @property
    def frame_dt(self) -> float:
        return self.data["frame_dt"]

    @property
    def solver(self) -> dict:
        return copy.deepcopy(self.data["solver"])

    def check_solver(self):
        """Validate the [solver] table against dcdc.sph.SPHConfig and the tension tables'
        phase names against the scene's phases; returns the config."""
        from ..sph import SPHConfig
        from ..sph.interfaces import tension_matrix, wall_tension_vector
        try:
            cfg = SPHConfig.from_dict(self.solver)
            names = list(self.data["phases"])
            tension_matrix(cfg.interfacial_tension, names)
            wall_tension_vector(cfg.wall_tension, names)
            return cfg
        except DcdcError as e:
            src = self.path.name if self.path else f"{self.name}.toml"
            line = _find_line(self.text, "solver")
            raise DcdcError(f"{src}: [solver]: {e}" + (f" (table at line {line})" if line else "")) from None

    @property
    def source(self) -> str:
        """The scene as messages name it: its file name, or NAME."""
        return self.path.name if self.path else self.name

    def variant(self, dim: int | None = None, resolution: float = 1.0,
                meshes: dict | None = None, domain: bool = True) -> dict:
        """The ``dim``-D variant at ``resolution`` (:func:`_transform`); a scene without
        ``[domain]`` gets the box around its walls and fluid (:func:`derive_domain`;
        ``meshes`` caches the placed meshes it loads) unless ``domain`` is False (its
        ``domain`` then stays None and no mesh is loaded)."""
        s = _transform(self.data, dim or self.dim, resolution)
        if domain and s["domain"] is None:
            s["domain"] = derive_domain(s, self.path.parent if self.path else None,
                                        {} if meshes is None else meshes, self.source)
        return s

    def realize(self, dim: int | None = None, resolution: float = 1.0,
                check: bool = True, frames: int | None = None,
                max_particles: float | None = None) -> ParticleSystem:
        """Particles of this scene (the ``dim``-D variant at ``resolution``); with ``check``,
        overlaps and fluid inside walls/outside the domain raise :class:`DcdcError`.
        The particle and memory budget (:mod:`.budget`; ``frames`` stored frames, a
        ``max_particles`` override) is checked before anything is allocated."""
        from ..geometry import sample_walls
        from ..neighbors import radius_search
        from . import budget

        meshes: dict = {}  # placed meshes, each loaded once
        s = self.variant(dim, resolution, meshes)
        base_dir = self.path.parent if self.path else None
        budget.check(_budget_view(s, base_dir, meshes), str(self.path.name) if self.path else self.name,
                     frames, max_particles)
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
            _check_mesh_walls(solids, wx, str(self.path.name) if self.path else self.name,
                              lo, hi, spacing, thickness)
        else:
            wx, wn = np.zeros((0, dim)), np.zeros((0, dim))
        names = list(s["phases"])
        phases = [Phase(n, p["density"], p["viscosity"], tuple(p["color"])) for n, p in s["phases"].items()]
        xs, vs, ph, births, blocks = [], [], [], [], []
        src = str(self.path.name) if self.path else self.name
        for i, f in enumerate(s["fluid"]):
            pts = _fluid_points(f, dim, spacing, anchor, lo, hi, solids, union, f"fluid[{i}]",
                                base_dir, meshes)
            label = f"fluid[{i}]" + (f" ({f['name'] or f['phase'] or '+'.join(f['phases'])})")
            line = _find_line(self.text, f"fluid[{i}]")
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
                x, v, b = _emitter_points(e, dim, spacing)
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
            domain=(lo - thickness, hi + thickness), birth=np.concatenate(births) if births else None, name=self.name,
            meta={"scene": self.name, "resolution": resolution, "scene_domain": [lo.tolist(), hi.tolist()], "scene_dim": self.dim,
                  "duration": s["duration"], "frame_dt": s["frame_dt"], "seed": s["seed"]},
            wall_sdf=union if solids else None)
        return system


def parse(text: str, source: str = "scene", path: Path | None = None, builtin=False) -> Scene:
    """Parse and validate scene TOML text."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DcdcError(f"{source}: not valid TOML: {e}") from None
    except RecursionError:
        raise DcdcError(f"{source}: arrays or tables nested too deeply to read") from None
    return Scene(validate(raw, text, source), text, path, builtin)


def load(path) -> Scene:
    """Load and validate a scene file."""
    p = Path(path)
    if not p.is_file():
        raise DcdcError(f"scene file {p} not found")
    try:
        text = p.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise DcdcError(f"cannot read scene file {p}: {e}") from None
    return parse(text, p.name, p.resolve())
