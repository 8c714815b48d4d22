"""What both scene importers share: reading the JSON, checked access to its items (unknown
keys and wrong types are one-line errors), mesh paths relative to the written TOML,
names, the domain, and the finished scene (TOML text, validated)."""
from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import DcdcError

DOMAIN_PAD = 0.05  # the domain: the bounds of walls and fluid grown by 5 % of their size


@dataclass
class Imported:
    """An imported scene: ``scene`` (the TOML table), ``text`` (the TOML), ``warnings``
    (one line per item that has no dcdc equivalent) and the source ``format``."""

    scene: dict
    text: str
    warnings: list = field(default_factory=list)
    format: str = ""

    def summary(self) -> str:
        s = self.scene
        return (f"{self.format} scene: {len(s.get('walls', {}))} wall(s), {len(s.get('fluid', []))} "
                f"fluid block(s), {len(s.get('emitter', []))} emitter(s), {len(s['phases'])} phase(s)")


def read_json(path) -> object:
    """The parsed JSON at ``path``; a missing or malformed file is a one-line error."""
    path = Path(path)
    if not path.is_file():
        raise DcdcError(f"{path}: no such file")
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as e:
        raise DcdcError(f"{path.name}: cannot read it ({e})") from None
    except json.JSONDecodeError as e:
        raise DcdcError(f"{path.name}: not valid JSON ({e.msg} at line {e.lineno}, column {e.colno})") from None
    except RecursionError:
        raise DcdcError(f"{path.name}: arrays or objects nested too deeply to read") from None


class Reader:
    """Checked access to the items of one scene JSON (``src`` names the file in messages)."""

    def __init__(self, src: str):
        self.src = src

    def fail(self, where: str, msg: str):
        raise DcdcError(f"{self.src}: {where} {msg}")

    def table(self, obj, where: str) -> dict:
        if not isinstance(obj, dict):
            self.fail(where, f"must be a JSON object (got {type(obj).__name__})")
        return obj

    def items(self, data: dict, key: str) -> list:
        v = data.get(key, [])
        if not isinstance(v, list):
            self.fail(key, f"must be a list (got {type(v).__name__})")
        return [self.table(x, f"{key}[{i}]") for i, x in enumerate(v)]

    def keys(self, obj: dict, where: str, known, what: str) -> None:
        """Every key of ``obj`` must be in ``known`` (or match one of its regex patterns)."""
        for k in obj:
            if k in known or any(isinstance(p, re.Pattern) and p.match(k) for p in known):
                continue
            self.fail(f"{where}:", f"unknown key {k!r} (not a {what} key that dcdc knows; a typo?)")

    def number(self, obj, key, where, default=None, positive=False, nonneg=False):
        v = obj.get(key, default)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.fail(f"{where}.{key}", f"must be a number (got {v!r})")
        if positive and not v > 0:
            self.fail(f"{where}.{key}", f"must be > 0 (got {v})")
        if nonneg and not v >= 0:
            self.fail(f"{where}.{key}", f"must be >= 0 (got {v})")
        return float(v)

    def integer(self, obj, key, where, default=None):
        v = obj.get(key, default)
        if v is None:
            return None
        if isinstance(v, bool) or not (isinstance(v, int) or (isinstance(v, float) and v.is_integer())):
            self.fail(f"{where}.{key}", f"must be an integer (got {v!r})")
        return int(v)

    def flag(self, obj, key, where, default=False) -> bool:
        v = obj.get(key, default)
        if isinstance(v, bool):
            return v
        if isinstance(v, int) and v in (0, 1):  # SPlisHSPlasH reads 0/1 as booleans
            return bool(v)
        self.fail(f"{where}.{key}", f"must be true or false (got {v!r})")

    def string(self, obj, key, where, default=None):
        v = obj.get(key, default)
        if v is not None and not isinstance(v, str):
            self.fail(f"{where}.{key}", f"must be a string (got {v!r})")
        return v

    def vec3(self, obj, key, where, default=None, scalar_ok=False):
        """Three numbers (``scalar_ok``: or one number, repeated)."""
        v = obj.get(key, default)
        if v is None:
            return None
        if scalar_ok and isinstance(v, (int, float)) and not isinstance(v, bool):
            v = [v, v, v]
        if not (isinstance(v, list) and len(v) == 3 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in v)):
            self.fail(f"{where}.{key}", f"must be a list of 3 numbers (got {v!r})")
        return [float(c) for c in v]


def toml_path(mesh: Path, output: Path | None) -> str:
    """A mesh path as the TOML at ``output`` should name it: relative to its directory when
    the mesh lies in it or one level up (SPlisHSPlasH's ``../models/``), else absolute (also
    without ``output``)."""
    mesh = mesh.resolve()
    if output is None:
        return str(mesh)
    rel = os.path.relpath(mesh, output.resolve().parent)
    return str(mesh) if rel.startswith(os.pardir + os.sep + os.pardir) else rel


def scene_name(text: str, fallback: str = "imported") -> str:
    """A dcdc name (letters, digits, _ and -, starting with a letter or _) from ``text``."""
    s = re.sub(r"[^A-Za-z0-9_\-]", "_", text.strip())
    if not s:
        return fallback
    return s if re.match(r"^[A-Za-z_]", s) else f"_{s}"


def unique(name: str, taken) -> str:
    n, k = name, 2
    while n in taken:
        n, k = f"{name}_{k}", k + 1
    return n


def domain(bounds: list, dim: int = 3) -> dict:
    """The scene domain: the box around ``bounds`` ([(lo, hi), ...] of walls, fluid and
    nozzles) grown by :data:`DOMAIN_PAD` of its size per axis (as
    :func:`dcdc.scene.importers.dlf.scene_system`)."""
    lo = np.min([np.asarray(b[0], float)[:dim] for b in bounds], axis=0)
    hi = np.max([np.asarray(b[1], float)[:dim] for b in bounds], axis=0)
    pad = DOMAIN_PAD * np.maximum(hi - lo, 1e-6)
    return {"min": [round(float(v), 6) for v in lo - pad], "max": [round(float(v), 6) for v in hi + pad]}


def finish(scene: dict, warnings: list, fmt: str, json_path: Path, output: Path | None,
           notes=()) -> Imported:
    """The scene as TOML (the import's source, notes and warnings as comments at the top),
    checked by the scene validator so that the file loads as written."""
    from .. import parse
    from ..random import to_toml
    head = [f"# imported by `dcdc scene import` from {json_path.name} ({fmt} scene)"]
    head += [f"# {n}" for n in notes]
    head += [f"# warning: {w}" for w in warnings]
    text = to_toml(scene, "\n".join(head))
    parse(text, output.name if output else f"{scene['name']}.toml", output)
    return Imported(scene, text, list(warnings), fmt)
