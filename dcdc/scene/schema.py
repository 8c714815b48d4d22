"""The scene file's schema: the keys of every table with their kinds and defaults
(docs/scenes.md), and :func:`validate`, which checks a parsed scene against them and fills
in the defaults. A wrong key or value raises :class:`~dcdc.errors.DcdcError` naming the
dotted field and its line (:mod:`.lines`)."""
from __future__ import annotations

import copy
import math
import re

import numpy as np

from ..particles import DEFAULT_RADIUS, FRAME_DT
from .lines import field_error


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
# the solids that walls and fluid blocks share
ROUND_SHAPES = {
    "sphere": {"center": ("vecL", REQ), "radius": ("L", REQ)},
    "cylinder": {"center": ("vecL", REQ), "radius": ("L", REQ), "height": ("L", REQ),
                 "axis": ("int", 1)},
}
WALL_SHAPES = {
    "box": {"min": ("vecL", REQ), "max": ("vecL", REQ), "hollow": ("bool", False),
            "open_top": ("bool", True)},
    **ROUND_SHAPES,
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
    **ROUND_SHAPES,
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


class Checker:
    """Checks values against the schema's kinds; :meth:`fail` raises the error naming the
    dotted field and its line in ``text`` (:func:`.lines.field_error`)."""

    def __init__(self, text: str, source: str):
        self.text = text
        self.source = source

    def fail(self, path: str, msg: str):
        raise field_error(self.text, self.source, path, msg)

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
                self.fail(path, "must be a list of at least two [radius, height] pairs")
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
    ck = Checker(text, source)
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
        shape, walls[name] = _shaped(ck, p, w, WALL_SHAPES, WALL_COMMON, dim)
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
        shape, fb = _shaped(ck, p, f, FLUID_SHAPES, FLUID_COMMON, dim)
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
        shape, em = _shaped(ck, p, e, EMITTER_SHAPES, {}, dim, default="nozzle")
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


def _shaped(ck: Checker, p: str, d, shapes: dict, common: dict, dim: int, default=None):
    """The wall, fluid block or emitter ``p`` as (shape, checked table): a table whose
    ``shape`` (``default`` when absent) picks its keys, ``common`` and ``shapes[shape]``."""
    if not isinstance(d, dict):
        ck.fail(p, "must be a table")
    shape = d.get("shape", default)
    if shape not in shapes:
        ck.fail(f"{p}.shape", f"must be one of {', '.join(shapes)} (got {shape!r})")
    return shape, ck.table(p, d, {**common, **shapes[shape]}, dim)


def _check_fluid_phases(ck: Checker, p: str, fb: dict, phases: dict) -> None:
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


def _check_box_nozzle(ck: Checker, p: str, e: dict, dim: int) -> None:
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


def _check_rotation(ck: Checker, p: str, d: dict) -> None:
    if d["rotation_degrees"] and (d["rotation_axis"] is None or not any(d["rotation_axis"])):
        ck.fail(f"{p}.rotation_axis", "must be a non-zero vector when rotation_degrees is set")
