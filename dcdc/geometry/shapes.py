"""Signed distance functions of built-in shapes (negative inside the solid).

Each function returns an SDF ``f(x: [N, d]) -> [N]`` and works in 2-D and 3-D unless noted.
Combine solids with :func:`union` (min) and :func:`subtract`.
"""
from __future__ import annotations

import numpy as np


def box(lo, hi):
    """Solid axis-aligned box [lo, hi] (exact Euclidean SDF)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    c, h = (lo + hi) / 2, (hi - lo) / 2

    def f(x):
        q = np.abs(x - c) - h
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(1), 0.0)
        return outside + inside
    return f


def container(lo, hi, open_top: bool = True, up_axis: int = 1):
    """Solid surrounding the hollow box [lo, hi]: the walls of a tank. With ``open_top`` the
    box is open along +``up_axis`` (its top face is pushed far away)."""
    hi = np.asarray(hi, dtype=np.float64).copy()
    if open_top:
        hi[up_axis] += 1e6
    inner = box(lo, hi)
    return lambda x: -inner(x)


def union(*sdfs):
    return lambda x: np.min(np.stack([f(x) for f in sdfs]), axis=0)


def subtract(a, b):
    """Solid ``a`` with solid ``b`` removed."""
    return lambda x: np.maximum(a(x), -b(x))
