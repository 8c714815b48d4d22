"""Fixed-radius neighbour search on a uniform cell list, compiled with numba.

One search serves the whole project: the SPH solver (support h), the CConv layers (radius
R) and the metrics. Particles are binned into cubic cells of edge >= radius with a counting
sort; each query then visits the 3^d surrounding cells. Both passes (count, fill) run in
parallel over queries (``numba.prange``), so both cores are used and no Python loop touches
a particle. Measured on this CPU in ../shared/MEASURED.md: ~9 ms for 10 k particles.

The result is a CSR list: neighbours of query ``i`` are ``index[row_splits[i]:row_splits[i+1]]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from .errors import DcdcError

_MAX_CELLS = 1 << 24  # grid cells allocated at most; the cell edge grows beyond that


@dataclass
class Neighbors:
    """CSR neighbour list: receivers (queries) i, senders (points) ``index``."""

    row_splits: np.ndarray  # int64 [n_queries + 1]
    index: np.ndarray  # int32 [n_edges]

    @property
    def n_edges(self) -> int:
        return int(self.row_splits[-1])

    @property
    def counts(self) -> np.ndarray:
        return np.diff(self.row_splits)

    def receivers(self) -> np.ndarray:
        """Receiver index of every edge, int32 [n_edges]."""
        return np.repeat(np.arange(len(self.row_splits) - 1, dtype=np.int32), self.counts)


def nearest_edges(receivers: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Index of each receiver's shortest edge: one entry per receiver that has edges, in
    receiver order (``receivers``, ``dist``: per edge; ties keep the first edge)."""
    order = np.lexsort((dist, receivers))  # by receiver, shortest first
    keep = np.ones(len(order), dtype=bool)
    keep[1:] = receivers[order][1:] != receivers[order][:-1]
    return order[keep]


def nearest_values(receivers: np.ndarray, dist: np.ndarray, values: np.ndarray,
                   n: int) -> np.ndarray:
    """[n, ...]: for each receiver the per-edge ``values`` row of its shortest edge (zeros
    for a receiver without edges), e.g. the normal of each particle's nearest wall
    particle."""
    first = nearest_edges(receivers, dist)
    out = np.zeros((n,) + values.shape[1:], dtype=values.dtype)
    out[receivers[first]] = values[first]
    return out


def _grid(lo: np.ndarray, hi: np.ndarray, radius: float):
    """Cell edge and padded grid shape covering [lo, hi] with cells of edge >= radius."""
    extent = np.maximum(hi - lo, radius)
    cell = float(radius)
    while True:
        shape = (np.floor(extent / cell).astype(np.int64) + 3)
        if np.prod(shape.astype(np.float64)) <= _MAX_CELLS:
            return cell, shape
        cell *= 1.5


@nb.njit(cache=True, parallel=True)
def _cell_keys(x, lo, cell, shape):
    """Flat cell index per point. Cell coordinates are clamped to [1, shape - 2]: the points
    a grid was built from always fall inside; a query outside the grid's box lands in a
    border cell, whose neighbourhood still holds every point within one cell of it."""
    n, d = x.shape
    keys = np.empty(n, dtype=np.int64)
    for i in nb.prange(n):
        key = 0
        stride = 1
        for k in range(d):
            c = int(np.floor((x[i, k] - lo[k]) / cell)) + 1
            c = min(max(c, 1), shape[k] - 2)
            key += c * stride
            stride *= shape[k]
        keys[i] = key
    return keys


@nb.njit(cache=True)
def _counting_sort(keys, n_cells):
    """Stable counting sort; returns (order, cell_start[n_cells + 1])."""
    start = np.zeros(n_cells + 1, dtype=np.int64)
    for k in keys:
        start[k + 1] += 1
    for c in range(n_cells):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(len(keys), dtype=np.int64)
    for i in range(len(keys)):
        k = keys[i]
        order[fill[k]] = i
        fill[k] += 1
    return order, start


@nb.njit(cache=True, parallel=True)
def _count(q, qkeys, p_sorted, order, start, rows, r2, exclude_self):
    """Neighbours per query. ``rows`` are the key offsets of the 3^(d-1) rows of cells
    around a query's cell; the three cells of a row are consecutive keys, so their points
    are one contiguous range ``start[c - 1]:start[c + 2]`` of the sorted points."""
    n = q.shape[0]
    d = q.shape[1]
    counts = np.zeros(n, dtype=np.int64)
    for i in nb.prange(n):
        q0 = q[i, 0]
        q1 = q[i, 1]
        q2 = q[i, 2] if d == 3 else 0.0
        c = 0
        for o in rows:
            cell = qkeys[i] + o
            for s in range(start[cell - 1], start[cell + 2]):
                if exclude_self and order[s] == i:
                    continue
                t = q0 - p_sorted[s, 0]
                dist2 = t * t
                t = q1 - p_sorted[s, 1]
                dist2 += t * t
                if d == 3:
                    t = q2 - p_sorted[s, 2]
                    dist2 += t * t
                if dist2 <= r2:
                    c += 1
        counts[i] = c
    return counts


@nb.njit(cache=True, parallel=True)
def _fill(q, qkeys, p_sorted, order, start, rows, r2, exclude_self, row_splits, index):
    """Write the neighbours counted by :func:`_count` (same traversal). The distance test is
    written out in both kernels on purpose: a shared inline helper made the SPH benchmark
    ≈ 10 % slower in two A/B runs (10:1, 10 k particles)."""
    n = q.shape[0]
    d = q.shape[1]
    for i in nb.prange(n):
        q0 = q[i, 0]
        q1 = q[i, 1]
        q2 = q[i, 2] if d == 3 else 0.0
        w = row_splits[i]
        for o in rows:
            cell = qkeys[i] + o
            for s in range(start[cell - 1], start[cell + 2]):
                j = order[s]
                if exclude_self and j == i:
                    continue
                t = q0 - p_sorted[s, 0]
                dist2 = t * t
                t = q1 - p_sorted[s, 1]
                dist2 += t * t
                if d == 3:
                    t = q2 - p_sorted[s, 2]
                    dist2 += t * t
                if dist2 <= r2:
                    index[w] = j
                    w += 1


@nb.njit(cache=True, parallel=True)
def _fill_capped(q, qkeys, p_sorted, order, start, rows, r2, exclude_self, tmp):
    """One pass instead of :func:`_count` + :func:`_fill`: the same traversal writes every
    candidate's index into the query's row of ``tmp`` [n, cap] and advances only on a hit
    (no branch on the distance test; the slot after the last hit is scratch). Returns the
    counts; a query with more than cap − 1 neighbours has an incomplete row (the caller
    then falls back to :func:`_fill`)."""
    n, d = q.shape
    last = tmp.shape[1] - 1
    counts = np.zeros(n, dtype=np.int64)
    for i in nb.prange(n):
        qi = q[i]
        out = tmp[i]
        w = 0
        for o in rows:
            cell = qkeys[i] + o
            for s in range(start[cell - 1], start[cell + 2]):
                j = order[s]
                dist2 = 0.0
                for k in range(d):  # the sum of squares in the order of _count/_fill
                    dist2 += (qi[k] - p_sorted[s, k]) ** 2
                out[min(w, last)] = j
                w += (dist2 <= r2) & ~(exclude_self & (j == i))
        counts[i] = w
    return counts


@nb.njit(cache=True, parallel=True)
def _compact(tmp, row_splits, index):
    for i in nb.prange(tmp.shape[0]):
        e0 = row_splits[i]
        for k in range(row_splits[i + 1] - e0):
            index[e0 + k] = tmp[i, k]


class CellGrid:
    """Points binned into a cell list of edge >= ``radius``, searchable by any queries.

    Build it once for points that do not move (the walls of an SPH scene) and call
    :meth:`search` every step: only the queries are binned then. Queries outside the box of
    the points are fine (their cells are clamped to the border, see :func:`_cell_keys`)."""

    def __init__(self, points: np.ndarray, radius: float, dtype=None):
        p = np.ascontiguousarray(points, dtype=dtype)
        if p.dtype not in (np.float32, np.float64):
            p = p.astype(np.float64)
        if p.ndim != 2 or p.shape[1] not in (2, 3):
            raise DcdcError(f"neighbour search needs [N, 2|3] points, got {p.shape}")
        if not radius > 0:
            raise DcdcError(f"search radius must be > 0 (got {radius})")
        if not np.isfinite(p).all():
            raise DcdcError("neighbour search got NaN/inf positions")
        self.points = p
        self.radius = float(radius)
        self.dim = p.shape[1]
        if len(p) == 0:
            return
        self.lo = p.min(0).astype(np.float64)
        self.cell, self.shape = _grid(self.lo, p.max(0).astype(np.float64), radius)
        self.keys = _cell_keys(p, self.lo, self.cell, self.shape)
        self.order, self.start = _counting_sort(self.keys, int(np.prod(self.shape)))
        self.sorted = p[self.order]
        # key offsets of the rows of cells (along axis 0) around a cell: 3 in 2-D, 9 in 3-D
        grids = np.meshgrid(*([np.arange(-1, 2)] * (self.dim - 1)), indexing="ij")
        strides = np.cumprod(self.shape[:-1])
        self.rows = sum(g.ravel() * s for g, s in zip(grids, strides)).astype(np.int64)

    def search(self, queries: np.ndarray | None = None, exclude_self: bool = False,
               capacity: int | None = None) -> Neighbors:
        """Points within ``radius`` (inclusive) of each query; ``queries=None`` searches the
        points themselves (then ``exclude_self`` may leave out the pairs (i, i)).

        ``capacity``: an expected bound on the neighbours of a query. Given, the search runs
        in one pass through an [n, capacity + 1] scratch array (:func:`_fill_capped`) and
        falls back to the exact two-pass fill when a query has more; the result is the same
        list either way. ``None`` (the SPH solver): the two passes count, fill."""
        same = queries is None
        q = self.points if same else np.ascontiguousarray(queries, dtype=self.points.dtype)
        if q.ndim != 2 or q.shape[1] != self.dim:
            raise DcdcError(f"neighbour search needs [N, {self.dim}] queries, got {q.shape}")
        nq = len(q)
        if nq == 0 or len(self.points) == 0:
            return Neighbors(np.zeros(nq + 1, dtype=np.int64), np.zeros(0, dtype=np.int32))
        if not same and not np.isfinite(q).all():
            raise DcdcError("neighbour search got NaN/inf positions")
        qkeys = self.keys if same else _cell_keys(q, self.lo, self.cell, self.shape)
        r2 = self.radius ** 2
        excl = bool(exclude_self and same)
        args = (q, qkeys, self.sorted, self.order, self.start, self.rows, r2, excl)
        tmp = None
        if capacity is not None:
            tmp = np.empty((nq, int(capacity) + 1), dtype=np.int32)
            counts = _fill_capped(*args, tmp)
        else:
            counts = _count(*args)
        row_splits = np.zeros(nq + 1, dtype=np.int64)
        np.cumsum(counts, out=row_splits[1:])
        index = np.empty(row_splits[-1], dtype=np.int32)
        if tmp is not None and counts.max() <= capacity:
            _compact(tmp, row_splits, index)
        else:
            _fill(*args, row_splits, index)
        return Neighbors(row_splits, index)


def radius_search(queries: np.ndarray, radius: float, points: np.ndarray | None = None,
                  exclude_self: bool = False, capacity: int | None = None) -> Neighbors:
    """All ``points`` within distance ``radius`` (inclusive) of each query.

    Args:
        queries: [Nq, d] positions (d = 2 or 3), float32 or float64.
        radius: search radius.
        points: [Np, d] positions to search; defaults to ``queries`` (self-search).
        exclude_self: with a self-search, leave out the pair (i, i).
        capacity: expected bound on neighbours per query (one-pass search, same result;
            :meth:`CellGrid.search`).
    """
    q = np.ascontiguousarray(queries)
    if q.dtype not in (np.float32, np.float64):
        q = q.astype(np.float64)
    if points is None:
        return CellGrid(q, radius).search(None, exclude_self, capacity)
    p = np.asarray(points)
    if q.ndim != 2 or p.ndim != 2 or q.shape[1] != p.shape[1] or q.shape[1] not in (2, 3):
        raise DcdcError(f"radius_search needs [N, 2|3] arrays, got {q.shape} and {p.shape}")
    return CellGrid(p, radius, dtype=q.dtype).search(q, capacity=capacity)
