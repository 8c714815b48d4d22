"""The error shown by ``dcdc render --compare``: mean nearest-particle distance.

For two particle sets A (e.g. ground truth) and B (e.g. a model's rollout) of the same
frame, d(A→B) is the mean over A of the distance to the nearest particle of B; the caption
reports the symmetric mean ½ (d(A→B) + d(B→A)) in mm: half the symmetric Chamfer distance
(with unsquared distances) of point-set comparison (Fan, Su & Guibas, CVPR 2017), one of
the distribution distances of docs/evaluation.md. It needs no particle correspondence, so it also
compares runs with different particle counts.

Nearest neighbours come from a uniform grid of B (cells of the particle spacing) searched
in growing shells of cells until no nearer particle can lie outside the shells visited.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _nearest(q, p, lo, cell, shape, start, order):
    nx, ny, nz = shape[0], shape[1], shape[2]
    out = np.empty(q.shape[0])
    kmax = max(nx, ny, nz)
    for i in range(q.shape[0]):
        c = np.empty(3, np.int64)
        for a in range(3):
            v = int(np.floor((q[i, a] - lo[a]) / cell))
            c[a] = min(max(v, 0), shape[a] - 1)
        best = np.inf
        for k in range(kmax + 1):
            # shell k: cells at Chebyshev distance exactly k from c
            for ix in range(max(c[0] - k, 0), min(c[0] + k, nx - 1) + 1):
                for iy in range(max(c[1] - k, 0), min(c[1] + k, ny - 1) + 1):
                    for iz in range(max(c[2] - k, 0), min(c[2] + k, nz - 1) + 1):
                        if max(abs(ix - c[0]), abs(iy - c[1]), abs(iz - c[2])) != k:
                            continue
                        key = (ix * ny + iy) * nz + iz
                        for s in range(start[key], start[key + 1]):
                            j = order[s]
                            d = 0.0
                            for a in range(3):
                                t = q[i, a] - p[j, a]
                                d += t * t
                            if d < best:
                                best = d
            # every point beyond shell k is at least k * cell away from a query in cell c
            # (queries outside the grid are clamped into it: they only get nearer points)
            if best < np.inf and np.sqrt(best) <= k * cell:
                break
        out[i] = np.sqrt(best)
    return out


def _pad3(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, np.float64)
    return x if x.shape[1] == 3 else np.concatenate([x, np.zeros((len(x), 3 - x.shape[1]))], 1)


def nearest_distance(queries: np.ndarray, points: np.ndarray, cell: float) -> np.ndarray:
    """Distance from each query to the nearest of ``points`` (both [N, 2|3])."""
    q, p = _pad3(queries), _pad3(points)
    if len(p) == 0:
        return np.full(len(q), np.inf)
    lo = p.min(0)
    shape = np.maximum(np.ceil((p.max(0) - lo) / cell).astype(np.int64), 1)
    idx = np.minimum(((p - lo) / cell).astype(np.int64), shape - 1)
    keys = (idx[:, 0] * shape[1] + idx[:, 1]) * shape[2] + idx[:, 2]
    order = np.argsort(keys, kind="stable")
    start = np.searchsorted(keys[order], np.arange(int(np.prod(shape)) + 1))
    return _nearest(q, p, lo, float(cell), shape, start, order)


def mean_nearest_distance(a: np.ndarray, b: np.ndarray, cell: float) -> float:
    """½ (mean over a of the distance to b + mean over b of the distance to a) [m]."""
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    return 0.5 * float(nearest_distance(a, b, cell).mean() + nearest_distance(b, a, cell).mean())
