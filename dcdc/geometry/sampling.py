"""Particle sampling on a regular lattice (spacing 2r), driven by signed distance functions."""
from __future__ import annotations

from typing import Callable

import numpy as np

SDF = Callable[[np.ndarray], np.ndarray]  # [N, d] -> [N]; < 0 inside the solid


def lattice(lo, hi, spacing: float, anchor=None) -> np.ndarray:
    """Points of the cubic lattice ``anchor + k * spacing`` inside the box [lo, hi] (inclusive,
    up to 1e-9 relative slack). ``anchor`` defaults to ``lo``."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    anchor = lo if anchor is None else np.asarray(anchor, dtype=np.float64)
    eps = 1e-9 * max(1.0, float(np.abs(np.concatenate([lo, hi])).max()))
    axes = []
    for a, b, c in zip(lo, hi, anchor):
        k0 = np.ceil((a - c - eps) / spacing)
        k1 = np.floor((b - c + eps) / spacing)
        axes.append(c + spacing * np.arange(k0, k1 + 1))
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def fill_box(lo, hi, spacing: float) -> np.ndarray:
    """Fluid particles filling the box [lo, hi]: lattice points at half a spacing from each
    face, so a block of side L holds L/spacing particles per axis."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    return lattice(lo + spacing / 2, hi - spacing / 2, spacing)


def fill_region(inside: Callable[[np.ndarray], np.ndarray], lo, hi, spacing: float,
                anchor=None) -> np.ndarray:
    """Lattice points in [lo, hi] where the predicate ``inside`` holds."""
    pts = lattice(lo, hi, spacing, anchor)
    return pts[inside(pts)] if len(pts) else pts


def sdf_normals(sdf: SDF, x: np.ndarray, h: float) -> np.ndarray:
    """Unit gradient of ``sdf`` at ``x`` by central differences with step ``h``."""
    d = x.shape[1]
    g = np.empty_like(x)
    for k in range(d):
        e = np.zeros(d)
        e[k] = h
        g[:, k] = (sdf(x + e) - sdf(x - e)) / (2 * h)
    norm = np.linalg.norm(g, axis=1, keepdims=True)
    return g / np.maximum(norm, 1e-12)


def sample_walls(sdf: SDF, lo, hi, spacing: float, thickness: float, anchor=None):
    """Wall particles: lattice points in [lo, hi] with ``-thickness <= sdf <= 0`` (a shell of
    the solid next to its surface), and their normals ∇sdf (pointing into the fluid).

    Returns (positions [M, d], normals [M, d]).
    """
    pts = lattice(lo, hi, spacing, anchor)
    s = sdf(pts)
    keep = (s <= 1e-9) & (s >= -thickness - 1e-9)
    pts = pts[keep]
    return pts, sdf_normals(sdf, pts, 0.25 * spacing)
