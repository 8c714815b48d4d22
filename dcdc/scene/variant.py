"""A scene's variants: the 2-D cross-section of a 3-D scene and its lengths scaled by a
resolution factor, walking the schema's kinds (:mod:`.schema`: vectors drop z, lengths
scale)."""
from __future__ import annotations

import copy
import math

from ..errors import DcdcError
from .schema import DOMAIN, EMITTER_SHAPES, FLUID_COMMON, FLUID_SHAPES, TOP, WALL_SHAPES


def transform(s: dict, dim: int, scale: float) -> dict:
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
