"""SPH smoothing kernels (compiled), dimension-generic.

The cubic spline of Monaghan (1992) in the support-radius convention used by SPlisHSPlasH
(Koschier et al. 2019, "Smoothed Particle Hydrodynamics Techniques for the Physics Based
Simulation of Fluids and Solids", eq. 4): with ``q = |x| / h`` and support radius ``h``

    W(q) = σ_d (6 q³ - 6 q² + 1)   for 0 <= q <= 1/2
    W(q) = σ_d  2 (1 - q)³         for 1/2 < q <= 1
    W(q) = 0                       otherwise,

    σ_2 = 40 / (7 π h²),   σ_3 = 8 / (π h³),

so that ∫ W dV = 1. The gradient is ∇W = W'(|x|) x / |x|.

:func:`cohesion_kernel` is the spline ``C`` of Akinci, Akinci & Teschner (2013), "Versatile
surface tension and adhesion for SPH fluids", eq. 2, used by the optional surface tension.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def sigma(h: float, dim: int) -> float:
    """Normalisation σ_d of the cubic spline with support ``h``."""
    if dim == 2:
        return 40.0 / (7.0 * math.pi * h * h)
    return 8.0 / (math.pi * h * h * h)


@nb.njit(cache=True, inline="always")
def w_of_r(r: float, h: float, s: float) -> float:
    """W at distance ``r`` given σ_d = ``s``."""
    q = r / h
    if q <= 0.5:
        return s * (6.0 * (q * q * q - q * q) + 1.0)
    if q <= 1.0:
        t = 1.0 - q
        return s * 2.0 * t * t * t
    return 0.0


@nb.njit(cache=True, inline="always")
def dw_of_r(r: float, h: float, s: float) -> float:
    """dW/dr at distance ``r`` given σ_d = ``s`` (<= 0)."""
    q = r / h
    if q <= 0.5:
        return s * (18.0 * q * q - 12.0 * q) / h
    if q <= 1.0:
        t = 1.0 - q
        return -s * 6.0 * t * t / h
    return 0.0


@nb.njit(cache=True, inline="always")
def cohesion_kernel(r: float, h: float) -> float:
    """Akinci et al. (2013) cohesion spline C(r) (eq. 2), 3-D normalisation 32/(π h⁹)."""
    if r > h or r <= 0.0:
        return 0.0
    c = 32.0 / (math.pi * h ** 9)
    a = (h - r) ** 3 * r ** 3
    if 2.0 * r > h:
        return c * a
    return c * (2.0 * a - h ** 6 / 64.0)


def _lattice_r2(spacing: float, h: float, dim: int) -> np.ndarray:
    """Squared distances from a node of the cubic lattice to every node within the box
    [-h, h]^d (those beyond h carry W = 0)."""
    n = int(np.ceil(h / spacing))
    ax = np.arange(-n, n + 1) * spacing
    grids = np.meshgrid(*([ax] * dim), indexing="ij")
    return sum(g.ravel() ** 2 for g in grids)


def lattice_volume(spacing: float, h: float, dim: int) -> float:
    """Rest volume consistent with the kernel: 1 / Σ_k W(k·spacing) over the cubic lattice.

    A lattice of spacing s would have the volume s^d per particle, but the discrete kernel
    sum differs from 1 by ~0.1 % (2-D, h = 2s), which an incompressible solver would try to
    remove by expanding a fluid at rest. With this volume the initial lattice has ψ = 1.
    """
    return 1.0 / float(cubic(np.sqrt(_lattice_r2(spacing, h, dim)), h, dim).sum())


def lattice_second_moment(spacing: float, h: float, dim: int) -> float:
    """M2 = Σ_k V0 W(|x_k|) |x_k|² over the rest lattice (V0 = :func:`lattice_volume`): the
    kernel's second moment, which sets the viscosity of a velocity filter (XSPH)."""
    r2 = _lattice_r2(spacing, h, dim)
    return lattice_volume(spacing, h, dim) * float((cubic(np.sqrt(r2), h, dim) * r2).sum())


def cubic_values(r: np.ndarray, h: float, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """W(r) and dW/dr of the cubic spline above as numpy array operations (for tables built
    once: the walls' volume map, the interfacial-tension sums)."""
    r = np.asarray(r, dtype=np.float64)
    q = r / h
    s = sigma(h, dim)
    t = np.clip(1.0 - q, 0.0, None)
    W = np.where(q <= 0.5, s * (6.0 * (q ** 3 - q ** 2) + 1.0), np.where(q <= 1.0, 2.0 * s * t ** 3, 0.0))
    dW = np.where(q <= 0.5, s * (18.0 * q * q - 12.0 * q) / h,
                  np.where(q <= 1.0, -6.0 * s * t ** 2 / h, 0.0))
    return W, dW


def cubic(r: np.ndarray, h: float, dim: int) -> np.ndarray:
    """Vectorised W(r) (for tests and analysis; the solver uses the compiled scalars)."""
    r = np.asarray(r, dtype=np.float64)
    s = sigma(h, dim)
    return np.array([w_of_r(float(v), h, s) for v in r.ravel()]).reshape(r.shape)


def cubic_grad(x: np.ndarray, h: float) -> np.ndarray:
    """Vectorised ∇W(x) for offsets ``x`` [N, d] (for tests)."""
    x = np.asarray(x, dtype=np.float64)
    d = x.shape[1]
    s = sigma(h, d)
    r = np.linalg.norm(x, axis=1)
    dw = np.array([dw_of_r(float(v), h, s) for v in r])
    out = np.zeros_like(x)
    nz = r > 1e-12
    out[nz] = (dw[nz] / r[nz])[:, None] * x[nz]
    return out
