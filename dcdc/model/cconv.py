"""Continuous convolution (CConv, Ummenhofer et al. 2020; paper eq. 3) in plain PyTorch + numba.

For a receiver i with neighbours j within radius R (self excluded for fluid→fluid)::

    out_i = Σ_j  Σ_c  G_c(Λ((x_j - x_i) / R)) · w(|x_j - x_i|) · f_j @ W_c        (eq. 3)

* Λ is the volume-preserving ball-to-cube mapping (ball → cylinder → cube, Griepentrog et
  al. 2008, as used by Ummenhofer et al. 2020); in 2-D the area-preserving disk → square map
  (the cylinder → cube step restricted to the plane).
* G_c are the trilinear (bilinear in 2-D) interpolation weights of the K^d filter cells
  (``align_corners``: the outer cell centres lie on the cube's faces), so the filter is
  g(u) = Σ_c G_c(u) W_c with W_c ∈ R^{C_in × C_out}.
* w(d) = (1 - d²/R²)³ clamped to [0, 1] is the window; with ``normalize`` the weights are
  divided by the receiver's window sum Σ_j w(d_ij).
* Relative coordinates are sender − receiver (Ummenhofer's f(x) = Σ f_i g(Λ(x_i − x)));
  the paper writes x_i − x_j, which is the same operator with a mirrored filter.

Implementation ("gather, then one GEMM", ../shared/MEASURED.md): the geometry of a step —
per edge the 2^d corner cells and weights (interpolation × window [/ window sum]) — is
computed once (:func:`build_geometry`) and shared by every layer on the same point sets.
A layer then either *spreads* Σ_edges weight·f_j into a per-receiver [cells·C_in] buffer and
applies one GEMM with the [cells·C_in, C_out] filter, or (when C_out ≤ C_in / 4, e.g. the
64 → 3 output layer) multiplies the features by the filter first and *collects* per edge.
The backward pass reuses the same kernels on the edges grouped by sender (the transposed
list), applied to grad_out:
``B = spread_by_sender(grad_out)``, ``grad_f = B @ W'ᵀ``, ``grad_W = fᵀ @ B``. Rows are
processed in cache-sized chunks through one reused buffer per call. No atomics anywhere:
every kernel owns its output rows, so results are deterministic.

Three backends compute the same thing: ``"fused"`` (default on CPU where torch links MKL:
:mod:`.fused` spreads each block of rows in a thread's cache and hands it to a
single-threaded GEMM inside the same numba parallel region, forward and sender-side
backward), ``"numba"`` (the chunks above, spread by numba then multiplied by torch; the
reference the fused kernels are tested against) and ``"torch"`` (sparse CSR matrix products,
runs on any device incl. CUDA; tested on CPU). ``DCDC_FUSED_CCONV=0`` turns the fused
kernels off.

Senders may be *virtual*: the density-conditioned layer (``modulation.py``) feeds one
modulated feature row per (receiver density, sender) pair or per edge; the geometry then
carries a remapped ``src`` index (:meth:`ConvGeometry.with_sources`).

Gradients: w.r.t. features and filter weights (and thus everything upstream of the
features: densities, velocities, MLPs). Positions enter only through the geometry, which
is treated as constant (as open3d's op does); see docs/model.md.
"""
from __future__ import annotations

import math
import threading
import warnings
from dataclasses import dataclass, field

import numba as nb
import numpy as np
import torch

from ..errors import DcdcError
from ..neighbors import Neighbors, radius_search
from . import fused as _fused
from .fused import _spread_row

DEFAULT_CPU_BACKEND = "fused" if _fused.AVAILABLE else "numba"  # what "auto" means on a CPU
CHUNK_BYTES = 8 << 20  # working-buffer size per chunk of rows (fits the L2/L3 caches well)


def _bf16_native() -> bool:
    """Whether torch's oneDNN has bf16 GEMMs in hardware (AVX-512 BF16 / AMX); elsewhere
    :func:`bf16_mm` emulates them."""
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        return False


BF16_NATIVE = _bf16_native()


# --------------------------------------------------------------------------- geometry kernels
@nb.njit(cache=True, inline="always")
def _ball_to_cube3(x, y, z):
    """Volume-preserving unit ball → cube [-1, 1]³ (ball → cylinder → cube)."""
    sq = x * x + y * y + z * z
    if sq < 1e-12:
        return 0.0, 0.0, 0.0
    norm = math.sqrt(sq)
    if 1.25 * z * z > x * x + y * y:
        s = math.sqrt(3.0 * norm / (norm + abs(z)))
        x *= s
        y *= s
        z = math.copysign(norm, z)
    else:
        s = norm / math.sqrt(x * x + y * y)
        x *= s
        y *= s
        z *= 1.5
    x, y = _disk_to_square(x, y)
    return x, y, z


@nb.njit(cache=True, inline="always")
def _disk_to_square(x, y):
    """Area-preserving unit disk → square [-1, 1]² (the cylinder → cube step)."""
    sq = x * x + y * y
    if sq < 1e-12:
        return 0.0, 0.0
    norm = math.sqrt(sq)
    if abs(y) <= abs(x):
        t = math.copysign(norm, x)
        return t, t * (4.0 / math.pi) * math.atan(y / x)
    t = math.copysign(norm, y)
    return t * (4.0 / math.pi) * math.atan(x / y), t


@nb.njit(cache=True, parallel=True)
def _geometry_kernel(rx, sx, row_splits, index, inv_r, K, use_window, normalize, cells, weights):
    n = rx.shape[0]
    d = rx.shape[1]
    scale = 0.5 * (K - 1)
    for i in nb.prange(n):
        e0 = row_splits[i]
        e1 = row_splits[i + 1]
        wsum = 0.0
        for e in range(e0, e1):
            j = index[e]
            px = (sx[j, 0] - rx[i, 0]) * inv_r
            py = (sx[j, 1] - rx[i, 1]) * inv_r
            pz = 0.0
            if d == 3:
                pz = (sx[j, 2] - rx[i, 2]) * inv_r
            r2 = px * px + py * py + pz * pz
            win = 1.0
            if use_window:
                win = 1.0 - r2
                win = win * win * win
                win = min(max(win, 0.0), 1.0)
            wsum += win
            if d == 3:
                ux, uy, uz = _ball_to_cube3(px, py, pz)
            else:
                ux, uy = _disk_to_square(px, py)
                uz = 0.0
            # cube [-1, 1] -> filter coordinates [0, K-1] (align_corners)
            u0 = (ux + 1.0) * scale
            u1 = (uy + 1.0) * scale
            u2 = (uz + 1.0) * scale
            i0 = min(max(int(math.floor(u0)), 0), K - 2)
            i1 = min(max(int(math.floor(u1)), 0), K - 2)
            i2 = min(max(int(math.floor(u2)), 0), K - 2)
            t0 = min(max(u0 - i0, 0.0), 1.0)
            t1 = min(max(u1 - i1, 0.0), 1.0)
            t2 = min(max(u2 - i2, 0.0), 1.0)
            ncorner = 8 if d == 3 else 4
            for k in range(ncorner):
                b0 = k & 1
                b1 = (k >> 1) & 1
                b2 = (k >> 2) & 1
                wk = (t0 if b0 else 1.0 - t0) * (t1 if b1 else 1.0 - t1)
                c = (i0 + b0) + K * (i1 + b1)
                if d == 3:
                    wk *= t2 if b2 else 1.0 - t2
                    c += K * K * (i2 + b2)
                cells[e, k] = c
                weights[e, k] = wk * win
        if normalize and wsum > 0.0:
            inv = 1.0 / wsum
            for e in range(e0, e1):
                for k in range(weights.shape[1]):
                    weights[e, k] *= inv


@nb.njit(cache=True)
def _transpose_kernel(row_splits, src, n_virtual):
    """Group the edges by (virtual) sender: CSR splits, edge permutation, receiver per edge."""
    n_edges = src.shape[0]
    splits = np.zeros(n_virtual + 1, dtype=np.int64)
    for e in range(n_edges):
        splits[src[e] + 1] += 1
    for v in range(n_virtual):
        splits[v + 1] += splits[v]
    fill = splits[:-1].copy()
    perm = np.empty(n_edges, dtype=np.int64)
    dst = np.empty(n_edges, dtype=np.int32)
    for i in range(row_splits.shape[0] - 1):
        for e in range(row_splits[i], row_splits[i + 1]):
            p = fill[src[e]]
            perm[p] = e
            dst[p] = i
            fill[src[e]] += 1
    return splits, perm, dst


# --------------------------------------------------------------------------- aggregation kernels
# fastmath lets LLVM vectorise the channel loops (3-4x faster here); the slices tell it
# that the destination segment and the source row are contiguous vectors.
@nb.njit(cache=True, parallel=True, fastmath=True)
def _spread(row_splits, src, cells, w, F, r0, r1, out):
    """out[i - r0, c·C:(c+1)·C] = Σ_{edges e of row i, corners k with cell c} w[e,k]·F[src[e]]
    (one receiver row: :func:`dcdc.model.fused._spread_row`)."""
    for ii in nb.prange(r1 - r0):
        i = r0 + ii
        _spread_row(out[ii], row_splits[i], row_splits[i + 1], src, cells, w, F)


@nb.njit(cache=True, parallel=True, fastmath=True)
def _spread_bf16(row_splits, src, cells, w, F, r0, r1, out):
    """:func:`_spread` accumulated in float32, written as bf16 bits (uint16, round to nearest
    even) so the bf16 GEMM reads it without a separate conversion pass."""
    C = F.shape[1]
    nk = cells.shape[1]
    width = out.shape[1]
    block = 16
    for b in nb.prange((r1 - r0 + block - 1) // block):
        acc = np.empty(width, dtype=np.float32)
        bits = acc.view(np.uint32)
        for ii in range(b * block, min((b + 1) * block, r1 - r0)):
            i = r0 + ii
            acc[:] = 0.0
            for e in range(row_splits[i], row_splits[i + 1]):
                fj = F[src[e]]
                for k in range(nk):
                    seg = acc[cells[e, k] * C:(cells[e, k] + 1) * C]
                    wk = w[e, k]
                    for c in range(C):
                        seg[c] += wk * fj[c]
            o = out[ii]
            for q in range(width):
                u = bits[q]
                o[q] = np.uint16((u + np.uint32(0x7FFF) + ((u >> np.uint32(16)) & np.uint32(1)))
                                 >> np.uint32(16))


@nb.njit(cache=True, parallel=True, fastmath=True)
def _collect(row_splits, src, cells, w, H, out):
    """out[i] = Σ_{edges e of row i, corners k} w[e,k]·H[src[e], cells[e,k]·C : +C].

    The output layer has C = d (2 or 3) channels: those are summed in registers (2× faster
    than through the output row; same order of terms)."""
    C = out.shape[1]
    nk = cells.shape[1]
    if C == 3 or C == 2:
        for i in nb.prange(out.shape[0]):
            a0 = out.dtype.type(0.0)
            a1 = out.dtype.type(0.0)
            a2 = out.dtype.type(0.0)
            for e in range(row_splits[i], row_splits[i + 1]):
                hj = H[src[e]]
                for k in range(nk):
                    b = cells[e, k] * C
                    wk = w[e, k]
                    a0 += wk * hj[b]
                    a1 += wk * hj[b + 1]
                    if C == 3:
                        a2 += wk * hj[b + 2]
            out[i, 0] = a0
            out[i, 1] = a1
            if C == 3:
                out[i, 2] = a2
        return
    for i in nb.prange(out.shape[0]):
        row = out[i]
        row[:] = 0.0
        for e in range(row_splits[i], row_splits[i + 1]):
            hj = H[src[e]]
            for k in range(nk):
                seg = hj[cells[e, k] * C:(cells[e, k] + 1) * C]
                wk = w[e, k]
                for c in range(C):
                    row[c] += wk * seg[c]


@nb.njit(cache=True, parallel=True, fastmath=True)
def _collect_edges(row_splits, src, cells, w, dA, r0, r1, out):
    """out[src[e]] = Σ_k w[e,k]·dA[i - r0, cells[e,k]·C : +C] for the edges of rows r0..r1.

    Only valid when ``src`` is injective (one edge per virtual sender: the per-edge path)."""
    C = out.shape[1]
    nk = cells.shape[1]
    for ii in nb.prange(r1 - r0):
        i = r0 + ii
        da = dA[ii]
        for e in range(row_splits[i], row_splits[i + 1]):
            o = out[src[e]]
            o[:] = 0.0
            for k in range(nk):
                seg = da[cells[e, k] * C:(cells[e, k] + 1) * C]
                wk = w[e, k]
                for c in range(C):
                    o[c] += wk * seg[c]


# --------------------------------------------------------------------------- geometry object
@dataclass
class ConvGeometry:
    """Everything a CConv layer needs about one (receivers, senders) pair at one step.

    ``row_splits``/``src``/``cells``/``weights`` list the edges grouped by receiver; ``src``
    is the sender (or virtual sender) row of the feature matrix. The sender-grouped
    (transposed) order is built lazily for the backward pass.
    """

    n_recv: int
    n_send: int  # rows of the feature matrix the layer receives (virtual senders)
    dim: int
    kernel_size: int
    row_splits: np.ndarray  # int64 [n_recv + 1]
    src: np.ndarray  # int32 [E]
    cells: np.ndarray  # int32 [E, 2^d]
    weights: np.ndarray  # [E, 2^d], float64 or the network's dtype (build_geometry's dtype)
    sender: np.ndarray  # int32 [E]: the real sender particle of each edge
    injective: bool = False  # every virtual sender has exactly one edge (per-edge features)
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def n_edges(self) -> int:
        return int(self.row_splits[-1])

    @property
    def n_cells(self) -> int:
        return self.kernel_size ** self.dim

    def receivers(self) -> np.ndarray:
        return np.repeat(np.arange(self.n_recv, dtype=np.int32), np.diff(self.row_splits))

    def weights_as(self, dtype: torch.dtype) -> np.ndarray:
        npdt = _np_dtype(dtype)
        if self.weights.dtype == npdt:
            return self.weights
        key = ("w", dtype)
        if key not in self._cache:
            self._cache[key] = np.ascontiguousarray(self.weights, dtype=npdt)
        return self._cache[key]

    def transposed(self, dtype: torch.dtype):
        """Edges grouped by virtual sender: (splits, receiver per edge, cells, weights)."""
        key = ("t", dtype)
        if key not in self._cache:
            if "perm" not in self._cache:
                self._cache["perm"] = _transpose_kernel(self.row_splits, self.src, self.n_send)
            splits, perm, dst = self._cache["perm"]
            self._cache[key] = (splits, dst, np.ascontiguousarray(self.cells[perm]),
                                np.ascontiguousarray(self.weights_as(dtype)[perm]))
        return self._cache[key]

    def with_sources(self, src: np.ndarray, n_send: int, injective: bool = False) -> "ConvGeometry":
        """The same edges reading their feature rows from ``src`` (virtual senders)."""
        g = ConvGeometry(self.n_recv, int(n_send), self.dim, self.kernel_size, self.row_splits,
                         np.ascontiguousarray(src, dtype=np.int32), self.cells, self.weights,
                         self.sender, injective)
        for key, val in self._cache.items():  # weights (other dtypes, on devices) are the same
            if key[0] in ("w", "edges"):
                g._cache[key] = val
        return g


def build_geometry(recv_x, send_x=None, radius: float = 0.1125, kernel_size: int = 4,
                   exclude_self: bool | None = None, normalize: bool = False, window: bool = True,
                   neighbors: Neighbors | None = None, dtype=np.float64) -> ConvGeometry:
    """Neighbour search + per-edge corner cells and weights for receivers ``recv_x``.

    Args:
        recv_x: [N, d] receiver positions (numpy or torch; detached).
        send_x: [M, d] sender positions; ``None`` = the receivers themselves.
        radius: CConv radius R (the networks use 4.5 r).
        kernel_size: K, the filter has K^d cells.
        exclude_self: leave out (i, i); default True for a self-convolution.
        normalize: divide the weights by each receiver's window sum.
        window: apply w(d) = (1 - d²/R²)³.
        neighbors: a precomputed :class:`Neighbors` list (skips the search).
        dtype: dtype of the stored weights (numpy or torch float32/float64). They are always
            computed in float64; float32 stores the float64 values rounded, exactly what
            ``weights_as(torch.float32)`` of a float64 geometry returns, without the float64
            array and the conversion pass (a float32 network passes its dtype).
    """
    rx = _as_numpy(recv_x)
    same = send_x is None
    sx = rx if same else _as_numpy(send_x)
    dim = rx.shape[1]
    if dim not in (2, 3) or sx.shape[1] != dim:
        raise DcdcError(f"CConv needs [N, 2|3] positions, got {rx.shape} and {sx.shape}")
    if kernel_size < 2:
        raise DcdcError(f"kernel_size must be >= 2 (got {kernel_size})")
    if exclude_self is None:
        exclude_self = same
    if neighbors is None:
        neighbors = radius_search(rx, radius, None if same else sx, exclude_self=exclude_self)
    n_edges = neighbors.n_edges
    nk = 2 ** dim
    npdt = _np_dtype(dtype)
    # normalising rescales the stored weights: do it in float64, then round (as before)
    kernel_dt = np.float64 if normalize else npdt
    cells = np.empty((n_edges, nk), dtype=np.int32)
    weights = np.empty((n_edges, nk), dtype=kernel_dt)
    if n_edges:
        _geometry_kernel(rx, sx, neighbors.row_splits, neighbors.index, 1.0 / float(radius),
                         int(kernel_size), bool(window), bool(normalize), cells, weights)
    if kernel_dt != npdt:
        weights = weights.astype(npdt)
    index = np.ascontiguousarray(neighbors.index, dtype=np.int32)
    return ConvGeometry(len(rx), len(sx), dim, int(kernel_size), neighbors.row_splits, index,
                        cells, weights, index)


def _np_dtype(dtype) -> np.dtype:
    """numpy dtype of a numpy or torch float dtype (float32 or float64)."""
    if isinstance(dtype, torch.dtype):
        dtype = {torch.float32: np.float32, torch.float64: np.float64}.get(dtype, dtype)
    dt = np.dtype(dtype)
    if dt not in (np.float32, np.float64):
        raise DcdcError(f"geometry weights must be float32 or float64 (got {dtype})")
    return dt


def _as_numpy(x) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    return np.ascontiguousarray(x, dtype=np.float64)


# --------------------------------------------------------------------------- numba backend
def _rows_per_chunk(width: int, itemsize: int) -> int:
    return max(32, CHUNK_BYTES // max(1, width * itemsize))


_workspace = threading.local()


def _buffer(rows: int, width: int, dtype: torch.dtype, slot: int = 0) -> torch.Tensor:
    """A [rows, width] scratch tensor from a per-thread pool that lives across calls.

    The chunk buffers of every layer and step come from here instead of a fresh 8 MiB
    allocation per call (whose pages the kernel had to fault in and zero each time). A
    buffer is only valid until the next request of the same ``slot`` on this thread: the
    callers consume each chunk (GEMM into their own output) before asking again."""
    pool = getattr(_workspace, "pool", None)
    if pool is None:
        pool = _workspace.pool = {}
    itemsize = torch.empty(0, dtype=dtype).element_size()
    need = rows * width * itemsize
    raw = pool.get(slot)
    if raw is None or raw.numel() < need:
        raw = pool[slot] = torch.empty(max(need, 1), dtype=torch.uint8)
    return raw[:need].view(dtype).view(rows, width)


def _forward_numba(F: torch.Tensor, W: torch.Tensor, geom: ConvGeometry, gemm_dtype=None):
    """Forward pass; F [V, Cin], W [cells, Cin, Cout] -> [R, Cout]."""
    ncell, cin, cout = W.shape
    R, V = geom.n_recv, geom.n_send
    w = geom.weights_as(F.dtype)
    Fn = F.detach().contiguous().numpy()
    out = torch.empty(R, cout, dtype=F.dtype)
    if R == 0:
        return out
    if 4 * cout * V <= cin * R:  # collect: filter first, intermediate [V, cells·Cout]
        # (only when clearly narrower: it is not chunked, the spread path is cache-blocked)
        W2 = W.detach().permute(1, 0, 2).reshape(cin, ncell * cout)
        H = _mm(F.detach(), W2, gemm_dtype).contiguous()
        _collect(geom.row_splits, geom.src, geom.cells, w, H.numpy(), out.numpy())
        return out
    # spread: gather per receiver, then one GEMM per chunk of rows
    Wf = W.detach().reshape(ncell * cin, cout)
    if gemm_dtype is not None:
        Wf = Wf.to(gemm_dtype)
    rows = min(R, _rows_per_chunk(ncell * cin, F.element_size()))
    if gemm_dtype == torch.bfloat16 and F.dtype == torch.float32:
        bits = _buffer(rows, ncell * cin, torch.int16)
        bitsn = bits.numpy().view(np.uint16)
        res = _buffer(rows, cout, torch.bfloat16, slot=1)
        for r0 in range(0, R, rows):
            r1 = min(R, r0 + rows)
            _spread_bf16(geom.row_splits, geom.src, geom.cells, w, Fn, r0, r1, bitsn)
            bf16_mm(bits[: r1 - r0].view(torch.bfloat16), Wf, out=res[: r1 - r0])
            out[r0:r1] = res[: r1 - r0]
        return out
    buf = _buffer(rows, ncell * cin, F.dtype)
    bufn = buf.numpy()
    for r0 in range(0, R, rows):
        r1 = min(R, r0 + rows)
        _spread(geom.row_splits, geom.src, geom.cells, w, Fn, r0, r1, bufn)
        A = buf[: r1 - r0]
        if gemm_dtype is None:
            torch.mm(A, Wf, out=out[r0:r1])
        else:
            out[r0:r1] = _mm(A, Wf, gemm_dtype)
    return out


def bf16_mm(a: torch.Tensor, b: torch.Tensor, out: torch.Tensor | None = None) -> torch.Tensor:
    """``a @ b`` for bf16 ``a``, ``b``: products accumulated in float32, the result rounded to
    bf16 (what oneDNN's bf16 GEMM returns). Where the CPU has no bf16 instructions
    (:data:`BF16_NATIVE` False) torch's bf16 GEMM is ~30× slower than float32, so the same
    numbers are computed as a float32 GEMM of the bf16 operands (exact products, float32
    sums; only the order of summation may differ): the bf16 rollouts can be validated on any
    CPU, and run faster only where the hardware has bf16."""
    if BF16_NATIVE:
        return torch.mm(a, b, out=out)
    res = torch.mm(a.float(), b.float()).to(torch.bfloat16)
    if out is None:
        return res
    out.copy_(res)
    return out


def _mm(a, b, gemm_dtype):
    if gemm_dtype is None:
        return a @ b
    if gemm_dtype == torch.bfloat16:
        return bf16_mm(a.to(gemm_dtype), b.to(gemm_dtype)).to(a.dtype)
    return (a.to(gemm_dtype) @ b.to(gemm_dtype)).to(a.dtype)


def _backward_numba(F, W, gout, geom: ConvGeometry, need_f: bool, need_w: bool):
    ncell, cin, cout = W.shape
    R, V = geom.n_recv, geom.n_send
    gout = gout.contiguous()
    gF = torch.zeros(V, cin, dtype=F.dtype) if need_f else None
    if geom.injective:
        # receiver side: A = spread(F) (recomputed), gW = Aᵀ g, dA = g Wᵀ, gF[e] = collect(dA)
        w = geom.weights_as(F.dtype)
        Fn = F.detach().contiguous().numpy()
        Wf = W.detach().reshape(ncell * cin, cout)
        gWf = torch.zeros(ncell * cin, cout, dtype=F.dtype) if need_w else None
        rows = min(max(R, 1), _rows_per_chunk(ncell * cin, F.element_size()))
        buf = _buffer(rows, ncell * cin, F.dtype)
        for r0 in range(0, R, rows):
            r1 = min(R, r0 + rows)
            g = gout[r0:r1]
            if need_w:
                _spread(geom.row_splits, geom.src, geom.cells, w, Fn, r0, r1, buf.numpy())
                gWf.addmm_(buf[: r1 - r0].t(), g)
            if need_f:
                dA = (g @ Wf.t()).contiguous()
                _collect_edges(geom.row_splits, geom.src, geom.cells, w, dA.numpy(), r0, r1,
                               gF.numpy())
        return gF, (gWf.reshape(ncell, cin, cout) if need_w else None)
    # sender side: B = spread_by_sender(g) [V, cells·Cout]; gF = B W'ᵀ; gW' = Fᵀ B
    splits, dst, tcells, tw = geom.transposed(F.dtype)
    W2 = W.detach().permute(1, 0, 2).reshape(cin, ncell * cout)
    gW2 = torch.zeros(cin, ncell * cout, dtype=F.dtype) if need_w else None
    gn = gout.numpy()
    Fd = F.detach()
    rows = min(max(V, 1), _rows_per_chunk(ncell * cout, F.element_size()))
    buf = _buffer(rows, ncell * cout, F.dtype)
    for v0 in range(0, V, rows):
        v1 = min(V, v0 + rows)
        _spread(splits, dst, tcells, tw, gn, v0, v1, buf.numpy())
        B = buf[: v1 - v0]
        if need_f:
            torch.mm(B, W2.t(), out=gF[v0:v1])
        if need_w:
            gW2.addmm_(Fd[v0:v1].t(), B)
    gW = gW2.reshape(cin, ncell, cout).permute(1, 0, 2) if need_w else None
    return gF, gW


def _fused_buffers(dtype: torch.dtype):
    """[parts, rows, width] scratch for :mod:`.fused`, from the same per-thread pool."""
    def get(parts, rows, width):
        return _buffer(parts * rows, width, dtype, slot=2).numpy().reshape(parts, rows, width)
    return get


def _fused_applies(F: torch.Tensor, W: torch.Tensor, geom: ConvGeometry, gemm_dtype) -> bool:
    """The fused kernels cover the spread form in float32/float64 GEMMs; the collect form
    (C_out ≤ C_in / 4), bf16 GEMMs and machines without torch's MKL keep the unfused path."""
    ncell, cin, cout = W.shape
    return (_fused.AVAILABLE and gemm_dtype is None and F.dtype in (torch.float32, torch.float64)
            and W.dtype == F.dtype and 4 * cout * geom.n_send > cin * geom.n_recv)


def _forward_fused(F: torch.Tensor, W: torch.Tensor, geom: ConvGeometry) -> torch.Tensor:
    """Forward pass with :func:`.fused.fused_rows`: out = spread(F) @ W_flat, blockwise."""
    ncell, cin, cout = W.shape
    Wf = W.detach().reshape(ncell * cin, cout).contiguous().numpy()
    out, _ = _fused.fused_rows(geom.row_splits, geom.src, geom.cells, geom.weights_as(F.dtype),
                               F.detach().contiguous().numpy(), ncell, Wf, None,
                               _fused_buffers(F.dtype))
    return torch.from_numpy(out)


def _backward_fused(F, W, gout, geom: ConvGeometry, need_f: bool, need_w: bool):
    """Sender side, fused: B = spread_by_sender(g) per block; gF = B W'ᵀ; gW' = Σ Fᵀ B."""
    ncell, cin, cout = W.shape
    splits, dst, tcells, tw = geom.transposed(F.dtype)
    Wm = W.detach().permute(0, 2, 1).reshape(ncell * cout, cin).contiguous().numpy()  # W'ᵀ
    gF, gW2 = _fused.fused_rows(splits, dst, tcells, tw, gout.contiguous().numpy(), ncell,
                                Wm if need_f else None,
                                F.detach().contiguous().numpy() if need_w else None,
                                _fused_buffers(F.dtype))
    gW = (torch.from_numpy(gW2).reshape(cin, ncell, cout).permute(1, 0, 2) if need_w else None)
    return (torch.from_numpy(gF) if need_f else None), gW


class _FusedCConv(torch.autograd.Function):
    """The numba operator with the fused spread → GEMM kernels where they apply."""

    @staticmethod
    def forward(ctx, F, W, geom, gemm_dtype):
        ctx.save_for_backward(F, W)
        ctx.geom = geom
        if _fused_applies(F, W, geom, gemm_dtype):
            return _forward_fused(F, W, geom)
        return _forward_numba(F, W, geom, gemm_dtype)

    @staticmethod
    def backward(ctx, gout):
        F, W = ctx.saved_tensors
        geom = ctx.geom
        need_f, need_w = ctx.needs_input_grad[0], ctx.needs_input_grad[1]
        if (_fused.AVAILABLE and not geom.injective and W.dtype == F.dtype
                and F.dtype in (torch.float32, torch.float64)):
            gF, gW = _backward_fused(F, W, gout.to(F.dtype), geom, need_f, need_w)
        else:
            gF, gW = _backward_numba(F, W, gout, geom, need_f, need_w)
        return gF, gW, None, None


class _NumbaCConv(torch.autograd.Function):
    @staticmethod
    def forward(ctx, F, W, geom, gemm_dtype):
        ctx.save_for_backward(F, W)
        ctx.geom = geom
        return _forward_numba(F, W, geom, gemm_dtype)

    @staticmethod
    def backward(ctx, gout):
        F, W = ctx.saved_tensors
        gF, gW = _backward_numba(F, W, gout, ctx.geom, ctx.needs_input_grad[0],
                                 ctx.needs_input_grad[1])
        return gF, gW, None, None


# --------------------------------------------------------------------------- torch backend
def _edge_entries(geom: ConvGeometry, dtype, device):
    """Row of M (receiver·cells + cell) and weight of every (edge, corner), built on ``device``.

    Only the per-edge arrays travel (int32 cells, the weights); the int64 row index is formed
    where it is used, so a CUDA step moves no [E·2^d] int64 arrays. Geometries made by
    :meth:`ConvGeometry.with_sources` share these (same receivers, cells and weights).
    """
    key = ("edges", dtype, str(device))
    if key not in geom._cache:
        counts = torch.from_numpy(np.diff(geom.row_splits)).to(device)
        recv = torch.repeat_interleave(torch.arange(geom.n_recv, device=device), counts,
                                       output_size=geom.n_edges)
        cells = torch.from_numpy(geom.cells).to(device)
        rows = (recv[:, None] * geom.n_cells + cells).reshape(-1)
        w = geom.weights_as(dtype) if dtype in (torch.float32, torch.float64) else geom.weights
        geom._cache[key] = (rows, torch.from_numpy(w).to(device=device, dtype=dtype).reshape(-1))
    return geom._cache[key]


def _sparse_matrix(geom: ConvGeometry, dtype, device, transpose: bool = False):
    """M [R·cells, V] with M[i·cells + c, src] = Σ weights (CSR), or its transpose Mt.

    Built on ``device`` (the sort that orders the entries runs there too); the transpose is
    built only when a backward pass asks for it.
    """
    key = ("sparse", transpose, dtype, str(device))
    if key not in geom._cache:
        rows, w = _edge_entries(geom, dtype, device)
        cols = torch.from_numpy(geom.src).to(device).long().repeat_interleave(2 ** geom.dim)
        shape = (geom.n_recv * geom.n_cells, geom.n_send)
        idx = torch.stack([cols, rows] if transpose else [rows, cols])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "sparse CSR support is in beta"
            M = torch.sparse_coo_tensor(idx, w, shape[::-1] if transpose else shape,
                                        check_invariants=False).coalesce()
            geom._cache[key] = M.to_sparse_csr()
    return geom._cache[key]


class _TorchCConv(torch.autograd.Function):
    """out = (M F).view(R, cells·Cin) @ W; pure torch sparse-dense products (any device)."""

    @staticmethod
    def forward(ctx, F, W, geom):
        ncell, cin, cout = W.shape
        A = (_sparse_matrix(geom, F.dtype, F.device) @ F).reshape(geom.n_recv, ncell * cin)
        ctx.save_for_backward(F, W)
        ctx.geom = geom
        return A @ W.reshape(ncell * cin, cout)

    @staticmethod
    def backward(ctx, gout):
        F, W = ctx.saved_tensors
        ncell, cin, cout = W.shape
        gF = gW = None
        if ctx.needs_input_grad[1]:
            A = _sparse_matrix(ctx.geom, F.dtype, F.device) @ F
            A = A.reshape(ctx.geom.n_recv, ncell * cin)
            gW = (A.t() @ gout).reshape(ncell, cin, cout)
        if ctx.needs_input_grad[0]:
            dA = (gout @ W.reshape(ncell * cin, cout).t()).reshape(-1, cin)
            gF = _sparse_matrix(ctx.geom, F.dtype, F.device, transpose=True) @ dA
        return gF, gW, None


# --------------------------------------------------------------------------- public op
def cconv(features: torch.Tensor, weight: torch.Tensor, geom: ConvGeometry,
          backend: str = "auto", gemm_dtype: torch.dtype | None = None) -> torch.Tensor:
    """Continuous convolution (eq. 3 without modulation): [V, Cin] → [R, Cout].

    Args:
        features: [geom.n_send, Cin] sender (or virtual sender) features.
        weight: [K^d, Cin, Cout] filter, cell index x-fastest (c = x + K·y + K²·z).
        geom: from :func:`build_geometry` (possibly ``with_sources``).
        backend: "fused" (CPU: :mod:`.fused`, the spread rows fed to the GEMM block by block
            in one parallel region), "numba" (CPU: spread chunk, then a torch GEMM; the
            reference the fused kernels are tested against), "torch" (any device) or "auto"
            (:data:`DEFAULT_CPU_BACKEND` on CPU, torch elsewhere).
        gemm_dtype: e.g. ``torch.bfloat16`` to run the GEMMs in bf16 (AMX) — inference only.
    """
    if features.shape[0] != geom.n_send:
        raise DcdcError(f"cconv: {features.shape[0]} feature rows for {geom.n_send} senders")
    if weight.shape[0] != geom.n_cells or weight.shape[1] != features.shape[1]:
        raise DcdcError(f"cconv: filter {tuple(weight.shape)} does not fit {geom.n_cells} cells "
                        f"× {features.shape[1]} channels")
    if backend == "auto":
        backend = DEFAULT_CPU_BACKEND if features.device.type == "cpu" else "torch"
    if backend in ("numba", "fused"):
        if gemm_dtype is not None and torch.is_grad_enabled() and (
                features.requires_grad or weight.requires_grad):
            gemm_dtype = None  # reduced-precision GEMMs are for inference only
        op = _FusedCConv if backend == "fused" else _NumbaCConv
        return op.apply(features, weight, geom, gemm_dtype)
    if backend == "torch":
        return _TorchCConv.apply(features, weight, geom)
    raise DcdcError(f"unknown CConv backend {backend!r} (fused, numba, torch, auto)")


# --------------------------------------------------------------------------- slow reference
def _ref_ball_to_cube(p):
    """Scalar re-statement of Λ (pure Python) for the reference implementation."""
    if len(p) == 2:
        x, y = p
        r = math.hypot(x, y)
        if r < 1e-6:
            return [0.0, 0.0]
        if abs(y) <= abs(x):
            return [math.copysign(r, x), math.copysign(r, x) * 4 / math.pi * math.atan(y / x)]
        return [math.copysign(r, y) * 4 / math.pi * math.atan(x / y), math.copysign(r, y)]
    x, y, z = p
    r = math.sqrt(x * x + y * y + z * z)
    if r < 1e-6:
        return [0.0, 0.0, 0.0]
    if 5 / 4 * z * z > x * x + y * y:  # polar caps of the ball -> end caps of the cylinder
        s = math.sqrt(3 * r / (r + abs(z)))
        cx, cy, cz = x * s, y * s, math.copysign(r, z)
    else:  # equatorial band -> mantle
        s = r / math.hypot(x, y)
        cx, cy, cz = x * s, y * s, 1.5 * z
    return _ref_ball_to_cube([cx, cy]) + [cz]


def reference_cconv(recv_x, send_x, features, weight, radius, exclude_self=True,
                    normalize=False, edge_features=None):
    """Slow per-edge CConv (brute-force neighbours, Python loops) for tests.

    ``edge_features(i, j)`` (optional) returns the feature vector used for edge (i, j),
    e.g. a density-modulated Γ_ij; default ``features[j]``.
    """
    rx = np.asarray(recv_x, dtype=np.float64)
    sx = np.asarray(send_x, dtype=np.float64)
    F = np.asarray(features, dtype=np.float64)
    W = np.asarray(weight, dtype=np.float64)
    ncell, cin, cout = W.shape
    d = rx.shape[1]
    K = round(ncell ** (1 / d))
    out = np.zeros((len(rx), cout))
    for i in range(len(rx)):
        acc = np.zeros(cout)
        wsum = 0.0
        for j in range(len(sx)):
            if exclude_self and j == i:
                continue
            rel = (sx[j] - rx[i]) / radius
            r2 = float(rel @ rel)
            if r2 > 1.0:
                continue
            win = min(max((1 - r2) ** 3, 0.0), 1.0)
            wsum += win
            u = [(c + 1) / 2 * (K - 1) for c in _ref_ball_to_cube(list(rel))]
            lo = [min(max(int(math.floor(a)), 0), K - 2) for a in u]
            t = [a - b for a, b in zip(u, lo)]
            f = F[j] if edge_features is None else np.asarray(edge_features(i, j))
            g = np.zeros(cout)
            for corner in np.ndindex(*([2] * d)):
                wk = np.prod([tk if bk else 1 - tk for tk, bk in zip(t, corner)])
                cell = sum((lo[a] + corner[a]) * K ** a for a in range(d))
                g += wk * (f @ W[cell])
            acc += win * g
        out[i] = acc / wsum if (normalize and wsum > 0) else acc
    return out
