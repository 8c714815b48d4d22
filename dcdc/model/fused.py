"""Fused CConv kernels: each block of receivers' cell rows is built in cache and fed straight
to the GEMM, in one parallel region per layer call (CPU, numba + the BLAS torch ships).

The operator is the one of :mod:`dcdc.model.cconv` (eq. 3)::

    out_i = Σ_j Σ_k w_ijk · f_j @ W_{c_ijk}  =  A_i @ W_flat,
    A_i[c·C_in : (c+1)·C_in] = Σ_{(j,k): c_ijk = c} w_ijk · f_j        (the "spread" row)

with the filter flattened to W_flat [cells·C_in, C_out]. The unfused operator spreads a chunk
of rows into a buffer (one numba parallel region), then multiplies it in torch (a second
thread pool) chunk by chunk. Here every thread takes groups of rows in turn and, for each
block of ``B`` of them, spreads the rows into its own [B, cells·C_in] buffer (L2-sized) and
calls a single-threaded GEMM on it that writes the block's outputs: the [N, cells·C_in]
matrix never exists and the threads meet once per layer call.

Backward (the same kernel on the edges grouped by sender, applied to ``g = ∂L/∂out``)::

    B_v = Σ_{(i,k): sender v} w · g_i  placed at cell c      (spread by sender, [cells·C_out])
    ∂L/∂f_v = B_v @ W'ᵀ,  W' [C_in, cells·C_out]              (per block, as the forward)
    ∂L/∂W' = Σ_v f_vᵀ B_v                       (per group of blocks, groups summed at the end)

The GEMM is the MKL that torch links (``sgemm_``/``dgemm_``, asked for one thread in the
worker via ``mkl_set_num_threads_local``), called through its address so the kernels stay
cacheable. Where torch has no MKL (e.g. ARM builds) :data:`AVAILABLE` is False and
:func:`dcdc.model.cconv.cconv` keeps the unfused operator (so does ``DCDC_FUSED_CCONV=0``).
The collect form (C_out ≤ C_in / 4, the output layer), bf16 GEMMs and the per-edge
(injective) backward stay unfused too.

Results: the forward is the unfused one bit for bit (same spread order, same GEMM); the
filter gradient sums the threads' partial products in a fixed order, equal to ~1e-7
relative (tests/test_cconv_fused.py).
"""
from __future__ import annotations

import ctypes
import os

import numba as nb
import numpy as np
import torch
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

# one thread's block of spread rows; A/B on this CPU: 1–2 MiB fastest, 192 KiB 1.3× slower
BLOCK_BYTES = 2 << 20
GROUPS_PER_THREAD = 4  # partial filter gradients per thread (the backward's work units)


def _blas_symbols():
    """Addresses of sgemm_, dgemm_ and mkl_set_num_threads_local in torch's library (or None)."""
    path = os.path.join(os.path.dirname(torch.__file__), "lib", "libtorch_cpu.so")
    try:
        lib = ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
        addr = [ctypes.cast(getattr(lib, name), ctypes.c_void_p).value
                for name in ("sgemm_", "dgemm_", "mkl_set_num_threads_local_")]
    except (OSError, AttributeError):
        return None
    return tuple(addr) if all(addr) else None


_SYMBOLS = _blas_symbols()
AVAILABLE = _SYMBOLS is not None and os.environ.get("DCDC_FUSED_CCONV", "1") != "0"


@intrinsic
def _call_gemm(typingctx, fptr, ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc):
    """Call the Fortran ?gemm_ at address ``fptr``; every other argument is an address."""
    args = (fptr, ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc)
    if not all(isinstance(t, types.Integer) for t in args):
        return None
    sig = types.void(*args)

    def codegen(context, builder, signature, llargs):
        ptr = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [ptr] * 13)
        fn = builder.inttoptr(llargs[0], fnty.as_pointer())
        builder.call(fn, [builder.inttoptr(v, ptr) for v in llargs[1:]])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def _call_set_threads(typingctx, fptr, nptr):
    """``mkl_set_num_threads_local_(&n)`` at address ``fptr``: returns the previous value."""
    if not (isinstance(fptr, types.Integer) and isinstance(nptr, types.Integer)):
        return None
    sig = types.int32(fptr, nptr)

    def codegen(context, builder, signature, llargs):
        ptr = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.IntType(32), [ptr])
        fn = builder.inttoptr(llargs[0], fnty.as_pointer())
        return builder.call(fn, [builder.inttoptr(llargs[1], ptr)])

    return sig, codegen


@nb.njit(cache=True, inline="always")
def _gemm(fptr, trans_a, M, N, K, A, lda, Bm, ldb, beta, C, ldc, scratch, scal):
    """Row-major C[M, N] = op(A)[M, K] @ B[K, N] (+ C if ``beta``); op = ᵀ if ``trans_a``.

    ``A``/``Bm``/``C`` are addresses; ``scratch`` an int32[8] and ``scal`` a float[2] array of
    the GEMM's dtype (holding 1 and 0/1) owned by the calling thread. Column-major BLAS
    computes Cᵀ = Bᵀ op(A)ᵀ, so the operands swap."""
    scratch[0] = 78  # 'N'
    scratch[1] = 84 if trans_a else 78  # 'T' / 'N'
    scratch[2] = N
    scratch[3] = M
    scratch[4] = K
    scratch[5] = ldb
    scratch[6] = lda
    scratch[7] = ldc
    scal[0] = 1.0
    scal[1] = 1.0 if beta else 0.0
    s = scratch.ctypes.data
    f = scal.ctypes.data
    _call_gemm(fptr, s, s + 4, s + 8, s + 12, s + 16, f, Bm, s + 20, A, s + 24,
               f + scal.itemsize, C, s + 28)


@nb.njit(cache=True, inline="always")
def _spread_row(row, e0, e1, src, cells, w, F):
    """row[c·C:(c+1)·C] = Σ_{edges e0..e1, corners k with cell c} w[e,k]·F[src[e]]."""
    C = F.shape[1]
    nk = cells.shape[1]
    row[:] = 0.0
    for e in range(e0, e1):
        fj = F[src[e]]
        for k in range(nk):
            seg = row[cells[e, k] * C:(cells[e, k] + 1) * C]
            wk = w[e, k]
            for c in range(C):
                seg[c] += wk * fj[c]


@intrinsic
def _fetch_add(typingctx, addr):
    """Atomically ``*addr += 1`` on an int64 at address ``addr``; returns the old value."""
    if not isinstance(addr, types.Integer):
        return None
    sig = types.int64(addr)

    def codegen(context, builder, signature, llargs):
        ptr = builder.inttoptr(llargs[0], ir.IntType(64).as_pointer())
        return builder.atomic_rmw("add", ptr, ir.Constant(ir.IntType(64), 1), "seq_cst")

    return sig, codegen


@nb.njit(cache=True, parallel=True, fastmath=True)
def _fused(row_splits, src, cells, w, F, Wm, out, X, acc, buf, counter, syms):
    """For every row i: A_i = spread row of F; ``out[i] = A_i @ Wm`` (if ``out`` has rows) and
    ``acc[g] += X[i]ᵀ A_i`` over the rows of group g (if ``acc`` has slots, zeroed).

    The rows form groups of consecutive blocks of B rows (one block per group without
    ``acc``, else ``acc.shape[0]`` groups); each of the P threads takes the next unclaimed
    group (``counter``, an int64[1] of 0) until none is left, so a thread the OS pauses
    holds up at most one group. What lands in ``acc[g]`` does not depend on which thread took
    g, so the summed result is deterministic. buf [P, B, width] holds each thread's block;
    syms = (gemm address, set-threads address)."""
    n = row_splits.shape[0] - 1
    P, B, width = buf.shape
    do_out = out.shape[0] > 0
    do_acc = acc.shape[0] > 0
    nblocks = (n + B - 1) // B
    groups = min(acc.shape[0], nblocks) if do_acc else nblocks
    per = ((nblocks + groups - 1) // groups) * B  # rows per group
    groups = (n + per - 1) // per
    for p in nb.prange(P):
        scratch = np.empty(8, dtype=np.int32)
        scal = np.empty(2, dtype=buf.dtype)
        scratch[0] = 1
        prev = _call_set_threads(syms[1], scratch.ctypes.data)  # 1 BLAS thread here
        blk = buf[p]
        g = _fetch_add(counter.ctypes.data)
        while g < groups:
            r_end = min(n, (g + 1) * per)
            for b0 in range(g * per, r_end, B):
                b1 = min(r_end, b0 + B)
                for ii in range(b1 - b0):
                    _spread_row(blk[ii], row_splits[b0 + ii], row_splits[b0 + ii + 1], src,
                                cells, w, F)
                if do_out:  # out[b0:b1] = blk @ Wm
                    _gemm(syms[0], False, b1 - b0, Wm.shape[1], width, blk.ctypes.data, width,
                          Wm.ctypes.data, Wm.shape[1], False, out[b0:b1].ctypes.data,
                          out.shape[1], scratch, scal)
                if do_acc:  # acc[g] += X[b0:b1]ᵀ @ blk
                    _gemm(syms[0], True, X.shape[1], width, b1 - b0, X[b0:b1].ctypes.data,
                          X.shape[1], blk.ctypes.data, width, True, acc[g].ctypes.data, width,
                          scratch, scal)
            g = _fetch_add(counter.ctypes.data)
        scratch[0] = prev
        _call_set_threads(syms[1], scratch.ctypes.data)


def fused_rows(row_splits, src, cells, w, F: np.ndarray, n_cells: int, Wm: np.ndarray | None,
               X: np.ndarray | None, buffers) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``spread(F) @ Wm`` [n, C_out] and/or ``Xᵀ spread(F)`` [C_x, n_cells·C].

    Args:
        row_splits, src, cells, w: edges grouped by output row (CSR, n rows), their feature
            row, corner cells and weights (the weights in F's dtype).
        F: [feature rows, C] contiguous, float32 or float64 (the dtype of everything).
        n_cells: K^d; a spread row is [n_cells·C].
        Wm: [n_cells·C, C_out] contiguous, or None (no product).
        X: [n, C_x] contiguous, or None (no accumulated product).
        buffers: ``buffers(parts, rows, width)`` returns a [parts, rows, width] scratch array
            of F's dtype.
    """
    n = len(row_splits) - 1
    dt = F.dtype
    width = n_cells * F.shape[1]
    parts = max(1, min(nb.get_num_threads(), n))
    rows = max(4, min(max(n, 1), BLOCK_BYTES // (width * dt.itemsize)))
    buf = buffers(parts, rows, width)
    out = np.empty((n, Wm.shape[1]) if Wm is not None else (0, 1), dtype=dt)
    # the filter gradient: GROUPS_PER_THREAD partial sums per thread (dynamic balance)
    acc = np.zeros((GROUPS_PER_THREAD * parts, X.shape[1], width) if X is not None
                   else (0, 1, 1), dtype=dt)
    syms = np.array([_SYMBOLS[0] if dt == np.float32 else _SYMBOLS[1], _SYMBOLS[2]],
                    dtype=np.int64)
    if n:
        _fused(row_splits, src, cells, w, F, Wm if Wm is not None else np.empty((1, 1), dt),
               out, X if X is not None else np.empty((0, 1), dt), acc, buf,
               np.zeros(1, dtype=np.int64), syms)
    return (out if Wm is not None else None, acc.sum(0) if X is not None else None)
