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


def sample_walls(sdf: SDF, lo, hi, spacing: float, thickness: float, anchor=None,
                 fluid_box=None):
    """Wall particles: lattice points in [lo, hi] with ``-thickness <= sdf <= 0`` (a shell of
    the solid next to its surface), and their normals ∇sdf (pointing into the fluid).

    ``fluid_box`` = (lo, hi), where fluid may be (the scene's domain): a shell point is kept
    only if a lattice point of the fluid space (sdf > 0 inside that box) lies within
    ``thickness + spacing·√d`` of it (:func:`reachable`). Where solids overlap, the union's
    ``min`` of their distance functions underestimates the depth, and the shell would reach
    points buried deep inside the union that no fluid particle can see.

    Returns (positions [M, d], normals [M, d]).
    """
    pts = lattice(lo, hi, spacing, anchor)
    s = sdf(pts)
    keep = (s <= 1e-9) & (s >= -thickness - 1e-9)
    if fluid_box is not None and keep.any():
        f_lo, f_hi = (np.asarray(b, dtype=np.float64) for b in fluid_box)
        near = (s > 1e-9) & (s <= thickness + 2 * spacing) & \
            ((pts >= f_lo) & (pts <= f_hi)).all(1)
        idx = np.flatnonzero(keep)
        keep[idx[~reachable(pts[idx], pts[near], thickness + spacing * np.sqrt(pts.shape[1]))]] = False
    pts = pts[keep]
    return pts, sdf_normals(sdf, pts, 0.25 * spacing)


def reachable(points: np.ndarray, free: np.ndarray, reach: float) -> np.ndarray:
    """Mask of ``points`` within ``reach`` of some point of ``free`` (a k-d tree query)."""
    if not len(free):
        return np.zeros(len(points), dtype=bool)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(free).query(points, distance_upper_bound=reach * (1 + 1e-9))
    return np.isfinite(d)
