"""The network's view of the walls: wall particles added where a lattice-sampled slanted wall
leaves a gap (:func:`fill_wall_gaps`, ``NetConfig.wall_fill_gaps``).

Scenes sample their walls on the particle lattice (spacing s = 2r, :mod:`dcdc.geometry.sampling`):
a wall slanted to the lattice becomes a staircase whose surface particles meet only
diagonally, √2 s apart, where the true surface runs between them. The SPH teacher's
boundary volumes close that gap; a network that sees only the particles does not, and a
particle pressed along such a wall slips between two of them into the wall.
"""
from __future__ import annotations

import numpy as np

from ..neighbors import radius_search

SURFACE_REACH, SURFACE_FRONT = 1.5, 0.6  # surface: no wall particle within 1.5 s lies > 0.6 s in front
PAIR_MIN, PAIR_MAX = 1.2, 1.5  # surface pairs this far apart (× s): lattice diagonals
SAME_FACE = 0.7  # ... that face the same way (cosine of the normals)
SQUARE = 0.75  # ... and whose midpoint has no third such particle this close (× s)


def surface_mask(wall_x: np.ndarray, wall_n: np.ndarray, spacing: float) -> np.ndarray:
    """The outermost layer: wall particles b with no wall particle j within 1.5 s in front
    of them by more than 0.6 s, (x_j − x_b)·n_b > 0.6 s (a deeper layer has one at s in
    front on a flat face, at 0.71 s on a 45° face; ``wall_n`` unit normals)."""
    nb = radius_search(wall_x, SURFACE_REACH * spacing, exclude_self=True)
    rec = nb.receivers()
    front = np.einsum("ij,ij->i", wall_x[nb.index] - wall_x[rec], wall_n[rec]) > SURFACE_FRONT * spacing
    return np.bincount(rec[front], minlength=len(wall_x)) == 0


def fill_wall_gaps(wall_x: np.ndarray, wall_n: np.ndarray, spacing: float):
    """(wall_x, wall_n) with a particle added in each diagonal gap of the walls' surface:
    between two surface particles a, b that are lattice diagonals of each other
    (1.2 s < |x_a − x_b| ≤ 1.5 s) and face the same way (n_a·n_b > 0.7), where no third
    surface particle (:func:`surface_mask`) facing that way lies within 0.75 s of their
    midpoint (on a flat face of the lattice four surface particles stand around it), at (x_a + x_b)/2 with the
    normal n̄ = (n_a + n_b)/|n_a + n_b|. Flat axis-aligned faces and the deeper layers of
    a wall get nothing; duplicates closer than s/4 are merged. The added rows follow the
    given ones, so the first M rows are unchanged."""
    wall_x = np.asarray(wall_x, dtype=np.float64)
    wall_n = np.asarray(wall_n, dtype=np.float64)
    if len(wall_x) < 2:
        return wall_x, wall_n
    nrm = wall_n / np.maximum(np.linalg.norm(wall_n, axis=1, keepdims=True), 1e-12)
    surf = np.flatnonzero(surface_mask(wall_x, nrm, spacing))
    if len(surf) < 2:
        return wall_x, wall_n
    xs, ns = wall_x[surf], nrm[surf]
    nb = radius_search(xs, PAIR_MAX * spacing, exclude_self=True)
    a = nb.receivers().astype(np.int64)
    b = nb.index.astype(np.int64)
    dist = np.linalg.norm(xs[b] - xs[a], axis=1)
    keep = ((a < b) & (dist > PAIR_MIN * spacing)
            & (np.einsum("ij,ij->i", ns[a], ns[b]) > SAME_FACE))
    if not keep.any():
        return wall_x, wall_n
    a, b = a[keep], b[keep]
    mid = 0.5 * (xs[a] + xs[b])
    mn = ns[a] + ns[b]
    mn /= np.maximum(np.linalg.norm(mn, axis=1, keepdims=True), 1e-12)
    # a gap: the pair is not the diagonal of a square of surface particles facing its way
    near = radius_search(mid, SQUARE * spacing, xs)
    rec = near.receivers()
    same = np.einsum("ij,ij->i", ns[near.index], mn[rec]) > SAME_FACE
    gap = np.bincount(rec[same], minlength=len(mid)) <= 2
    mid, mn = mid[gap], mn[gap]
    # none on top of an existing wall particle, one per gap
    if len(mid):
        free = radius_search(mid, 0.25 * spacing, wall_x).counts == 0
        mid, mn = mid[free], mn[free]
    if not len(mid):
        return wall_x, wall_n
    dup = radius_search(mid, 0.25 * spacing, exclude_self=True)
    first = np.ones(len(mid), dtype=bool)
    rec = dup.receivers()
    first[rec[dup.index < rec]] = False
    return (np.concatenate([wall_x, mid[first]]), np.concatenate([wall_n, mn[first]]))


class FilledWalls:
    """:func:`fill_wall_gaps` per scene of a batch, recomputed only when the walls change
    (static in a rollout)."""

    def __init__(self):
        self._key = None
        self._out = None

    def get(self, wall_x: np.ndarray, wall_n: np.ndarray, spacing: float, wall_offsets=None):
        """(wall_x, wall_n, new wall offsets or None) for the scenes' wall rows."""
        key = (float(spacing), None if wall_offsets is None else tuple(np.asarray(wall_offsets).tolist()))
        if (self._key is not None and self._key[0] == key and np.array_equal(self._key[1], wall_x)
                and np.array_equal(self._key[2], wall_n)):
            return self._out
        spans = ([(0, len(wall_x))] if wall_offsets is None
                 else list(zip(wall_offsets[:-1], wall_offsets[1:])))
        xs, ns, counts = [], [], []
        for lo, hi in spans:
            x, n = fill_wall_gaps(wall_x[lo:hi], wall_n[lo:hi], spacing)
            xs.append(x)
            ns.append(n)
            counts.append(len(x))
        offs = None if wall_offsets is None else np.concatenate([[0], np.cumsum(counts)])
        self._out = (np.concatenate(xs), np.concatenate(ns), offs)
        self._key = (key, np.array(wall_x, copy=True), np.array(wall_n, copy=True))
        return self._out
