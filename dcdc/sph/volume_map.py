"""Walls as a smooth volume map (Koschier & Bender 2017, "Density maps for improved SPH
boundary handling"; Bender, Kugelstadt, Weiler & Koschier 2019, "Implicit frictional
boundary handling for SPH", IEEE TVCG 26(10), the "volume maps").

The walls enter the number-density estimate and the pressure operator only through two
fields of the fluid particle's position (docs/sph.md, "Walls"):

    Ψ(x)  = ∫_solid W(x - y) dy          (the walls' share of ψ_i = ρ_i / ρ0_i)
    ∇Ψ(x) = ∫_solid ∇W(x - y) dy         (the walls' part S_b,i of the pressure operator)

Sampled wall particles approximate both integrals by sums Σ_b V_b W(x - x_b), which ripple
along the wall with the particle spacing: a fluid particle under pressure p_i is pushed
towards the closest wall particle with an acceleration ∝ p_i ∂Ψ/∂x_tangential / ρ0_i. Under
a heavy layer that "egg-crate" force is several g for a light particle (it is ∝ 1/ρ0_i),
which glued light fluid to floors and walls (measured, docs/sph.md). The integrals of a
smooth solid have no such ripple, so a fluid particle slides along a wall freely (free slip)
and only the wall-normal push remains.

Ψ is tabulated once per simulator on a regular grid (spacing ``cell`` = r/2 = h/8) by an
FFT convolution of the solid's volume fraction χ with W, and interpolated at the particles
each substep by cubic convolution (Catmull-Rom), whose derivative gives ∇Ψ, so S_b = ∇Ψ
exactly (C¹, no ripple along a wall). χ comes from the walls' signed distance function
when the scene provides one (:attr:`ParticleSystem.wall_sdf`: the exact solid, curved and
inclined walls included), else from the wall particles, each standing for the lattice cell
(a cube of side 2r) around it (exact for walls aligned with the lattice). The map's surface
lies :func:`wall_offset` behind the walls' so that the rest lattice keeps ψ = 1 at a flat
wall (measured: ψ of the first fluid row 0.999 in 3-D and 1.001 in 2-D; wall particles:
1.000 by construction).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numba as nb
import numpy as np

from ..errors import DcdcError
from ..neighbors import CellGrid
from .kernels import cubic_values

MAX_NODES = 20_000_000  # grid nodes; beyond this the cell is coarsened (and said so)


def _kernel_stencil(cell: float, h: float, d: int):
    """W and ∇W (cubic spline, :mod:`dcdc.sph.kernels`) at the grid offsets k·cell within
    the support: arrays [(2m+1)^d] and [(2m+1)^d, d]."""
    m = int(math.ceil(h / cell))
    ax = np.arange(-m, m + 1) * cell
    z = np.stack(np.meshgrid(*([ax] * d), indexing="ij"), axis=-1)
    r = np.sqrt((z ** 2).sum(-1))
    W, dW = cubic_values(r, h, d)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(r > 0, dW / r, 0.0)
    return W, f[..., None] * z


def _convolve(chi: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Linear (not circular) convolution of ``chi`` with the odd-sized stencil ``k``,
    cropped to ``chi``'s shape ('same'), by real FFTs (scipy.fft, all threads)."""
    from scipy import fft

    m = [(s - 1) // 2 for s in k.shape]
    shape = [fft.next_fast_len(a + b - 1, real=True) for a, b in zip(chi.shape, k.shape)]
    f32 = np.float32  # single precision halves the time; Ψ needs ~1e-6, not 1e-15
    full = fft.irfftn(fft.rfftn(chi.astype(f32), shape, workers=-1)
                      * fft.rfftn(k.astype(f32), shape, workers=-1), shape, workers=-1)
    return full[tuple(slice(mm, mm + n) for mm, n in zip(m, chi.shape))].astype(np.float64)


@nb.njit(cache=True, inline="always")
def _catmull_rom(t, w, dw):
    """Cubic convolution weights (Catmull-Rom, Keys 1981 with a = -1/2) of the nodes
    k-1 .. k+2 at the fraction t in [0, 1) past node k, and their t-derivatives."""
    t2 = t * t
    t3 = t2 * t
    w[0] = 0.5 * (-t3 + 2.0 * t2 - t)
    w[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0)
    w[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t)
    w[3] = 0.5 * (t3 - t2)
    dw[0] = 0.5 * (-3.0 * t2 + 4.0 * t - 1.0)
    dw[1] = 0.5 * (9.0 * t2 - 10.0 * t)
    dw[2] = 0.5 * (-9.0 * t2 + 8.0 * t + 1.0)
    dw[3] = 0.5 * (3.0 * t2 - 2.0 * t)


@nb.njit(cache=True, parallel=True)
def _sample(x, lo, inv_cell, shape, psi, out_psi, out_grad):
    """Ψ and its exact gradient at the points ``x`` from the node table ``psi`` (flat, C
    order) by cubic convolution in every axis (C¹, interpolation error O(cell⁴)); points
    without a full 4^d stencil inside the grid get 0 (the grid covers the domain with a
    margin, so none does in a run)."""
    n, d = x.shape
    stride = np.ones(d, dtype=np.int64)
    for a in range(d - 2, -1, -1):
        stride[a] = stride[a + 1] * shape[a + 1]
    for i in nb.prange(n):
        w = np.empty((d, 4))
        dw = np.empty((d, 4))
        base = 0
        inside = True
        for a in range(d):
            u = (x[i, a] - lo[a]) * inv_cell
            ka = int(math.floor(u))
            if ka < 1 or ka >= shape[a] - 2:
                inside = False
                break
            base += (ka - 1) * stride[a]
            _catmull_rom(u - ka, w[a], dw[a])
        out_psi[i] = 0.0
        for a in range(d):
            out_grad[i, a] = 0.0
        if not inside:
            continue
        sp = 0.0
        g0 = g1 = g2 = 0.0
        if d == 2:
            for p in range(4):
                for q in range(4):
                    v = psi[base + p * stride[0] + q * stride[1]]
                    sp += w[0, p] * w[1, q] * v
                    g0 += dw[0, p] * w[1, q] * v
                    g1 += w[0, p] * dw[1, q] * v
        else:
            for p in range(4):
                for q in range(4):
                    for t in range(4):
                        v = psi[base + p * stride[0] + q * stride[1] + t * stride[2]]
                        wpq = w[0, p] * w[1, q]
                        sp += wpq * w[2, t] * v
                        g0 += dw[0, p] * w[1, q] * w[2, t] * v
                        g1 += w[0, p] * dw[1, q] * w[2, t] * v
                        g2 += wpq * dw[2, t] * v
        out_psi[i] = sp
        out_grad[i, 0] = g0 * inv_cell
        out_grad[i, 1] = g1 * inv_cell
        if d == 3:
            out_grad[i, 2] = g2 * inv_cell


class VolumeMap:
    """Tabulated Ψ and ∇Ψ of the walls (module doc); :meth:`sample` evaluates both."""

    def __init__(self, chi: np.ndarray, lo: np.ndarray, cell: float, h: float,
                 down: np.ndarray | None = None,
                 contact: tuple[np.ndarray, float, float] | None = None):
        d = chi.ndim
        Wk, Gk = _kernel_stencil(cell, h, d)
        norm = Wk.sum()
        Wk = Wk / norm  # the stencil's quadrature of ∫W = 1 (times cell^d)
        self.lo = np.asarray(lo, dtype=np.float64)
        self.cell = float(cell)
        self.h = float(h)
        self.shape = np.array(chi.shape, dtype=np.int64)
        # ∇Ψ is the derivative of the interpolant (:func:`_sample`), so S_b = ∇Ψ exactly
        self.psi = np.ascontiguousarray(_convolve(chi, Wk).reshape(-1))
        # the walls' share Φ = Ψ + A Ψ_c of a balanced wall (:func:`balanced_wall`); the
        # contact (:meth:`keep_outside`) keeps reading Ψ alone
        self.contact = None
        if contact is not None:
            # (node table of the signed distance from the map's surface, support h_c, A)
            dist, hc, amp = contact
            z = np.linspace(0.0, hc, 2001)
            slope = np.gradient(contact_profile(z, hc, d), z)
            slope[-1] = 0.0
            # P_c re-integrated from its piecewise-linear slope (P_c(h_c) = 0), so that the
            # sampled value's derivative is exactly the sampled slope (C¹, no table kinks)
            steps = 0.5 * (slope[1:] + slope[:-1]) * np.diff(z)
            prof = -np.concatenate([np.cumsum(steps[::-1])[::-1], [0.0]])
            self.contact = (np.ascontiguousarray(dist, dtype=np.float64).reshape(-1), z, prof,
                            slope, float(amp))
        # the hydrostatic moment along the unit vector ``down``: q(x) = ∫_solid (down·(y - x))
        # ∇_x W(x - y) dy, i.e. the stencil -(down·z) ∇W(z) with z = x - y
        self.moment = None
        if down is not None:
            z = np.stack(np.meshgrid(*([cell * np.arange(-(n // 2), n // 2 + 1)
                                        for n in Wk.shape]), indexing="ij"), axis=-1)
            dz = z @ np.asarray(down, dtype=np.float64)
            # the quadrature weights of ∇W get the same normalisation as those of W
            self.moment = [np.ascontiguousarray(_convolve(chi, -dz * Gk[..., a] / norm).reshape(-1))
                           for a in range(d)]

    @property
    def dim(self) -> int:
        return len(self.shape)

    def sample(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Ψ(x) [n], ∇Ψ(x) [n, d]) at positions ``x`` [n, d]: the walls' share of ψ and of
        the pressure operator (Φ and ∇Φ of a balanced wall)."""
        psi, grad = self._interp(self.psi, x)
        if self.contact is not None:
            # Ψ_c = P_c(s) of the interpolated signed distance s: exact at flat walls (the
            # cubic interpolant reproduces a linear s), C¹ in corners. Tabulating Ψ_c itself
            # (support 2r = 4 cells) overestimated its slope at the first row 1.8× (measured)
            dist, z, prof, dprof, amp = self.contact
            s, ds = self._interp(dist, x)
            a = np.minimum(np.abs(s), z[-1])
            k = np.clip(np.searchsorted(z, a, side="right") - 1, 0, len(z) - 2)
            t = a - z[k]
            curv = (dprof[k + 1] - dprof[k]) / (z[k + 1] - z[k])
            slope = dprof[k] + curv * t  # P_c'(|s|), piecewise linear
            val = prof[k] + dprof[k] * t + 0.5 * curv * t * t  # its exact antiderivative
            # inside the solid P_c(-a) = 2 P_c(0) - P_c(a) (= 1 - P_c(a)): C¹ across s = 0
            psi = psi + amp * np.where(s < 0, 2.0 * prof[0] - val, val)
            grad = grad + (amp * slope)[:, None] * ds
        return psi, grad

    def keep_outside(self, x: np.ndarray, v: np.ndarray, limit: float = 0.5,
                     iterations: int = 3, target: float | None = None) -> int:
        """Wall contact: move every point with Ψ(x) > ``limit`` back to Ψ = ``target``
        (default: ``limit``) along ∇Ψ (Newton steps on Ψ) and remove its velocity into the
        wall (an inelastic, frictionless collision); ``x`` and ``v`` are changed in place;
        returns how many points moved.

        The pressure solve pushes only particles under pressure (p_i ∇Ψ); spray (p = 0) would
        fly into the solid, where Ψ -> 1 and ∇Ψ -> 0 leave nothing to push it out. Ψ = 1/2 is
        the map's surface at a flat wall; fluid at rest never comes near it (Ψ ≈ 0.16 at the
        first row, ≈ 0.4 in a 3-D corner), so only particles that reach the solid feel this."""
        target = limit if target is None else target
        psi, _ = self._interp(self.psi, x)
        hit = np.flatnonzero(psi > limit)
        if not len(hit):
            return 0
        xh = x[hit]
        for _ in range(iterations):
            ph, gh = self._interp(self.psi, xh)
            g2 = (gh ** 2).sum(1)
            step = np.where((ph > target) & (g2 > 1e-12), (ph - target) / np.maximum(g2, 1e-300), 0.0)
            # deep in the solid ∇Ψ -> 0 and the Newton step would blow up: move at most h/4
            # (a particle radius at the default support) per iteration
            step = np.minimum(step, 0.25 * self.h / np.sqrt(np.maximum(g2, 1e-300)))
            xh -= step[:, None] * gh
        x[hit] = xh
        _, gh = self._interp(self.psi, xh)
        n = gh / np.maximum(np.linalg.norm(gh, axis=1, keepdims=True), 1e-300)
        vn = (v[hit] * n).sum(1)
        v[hit] -= np.maximum(vn, 0.0)[:, None] * n
        return len(hit)

    def _interp(self, table, x):
        n = len(x)
        val = np.empty(n)
        grad = np.empty((n, self.dim))
        if n:
            _sample(np.ascontiguousarray(x, dtype=np.float64), self.lo, 1.0 / self.cell,
                    self.shape, table, val, grad)
        return val, grad

    def tangential_moment(self, x: np.ndarray, grad_psi: np.ndarray) -> np.ndarray:
        """The wall-parallel part of the hydrostatic moment q(x) [n, d] (None without one):
        q - (q·n)n with n = ∇Ψ/|∇Ψ|. A fluid particle next to a wall sees its pressure
        gradient only through the fluid half of its kernel; extrapolating the hydrostatic
        pressure p_i + ρ̄ |g| down·(y - x_i) into the wall (Adami, Hu & Adams 2012) adds
        -(ρ̄|g|/ρ0_i) q(x_i) to its acceleration. The normal part is left to the pressure
        solve (which keeps ψ = 1 at the wall), the tangential part restores buoyancy along
        side walls."""
        if self.moment is None:
            return None
        q = np.stack([self._interp(m, x)[0] for m in self.moment], axis=1)
        norm = np.linalg.norm(grad_psi, axis=1, keepdims=True)
        n = np.where(norm > 1e-12, grad_psi / np.maximum(norm, 1e-300), 0.0)
        return q - (q * n).sum(1, keepdims=True) * n


@lru_cache(maxsize=16)
def half_space_profile(h: float, dim: int, n: int = 801) -> tuple[np.ndarray, np.ndarray]:
    """Ψ of a flat solid half-space against the distance z from its surface, tabulated at
    ``n`` points of [0, h]: Ψ(z) = ∫_z^h M, with the kernel's marginal M(z) = ∫ W(z, x_⊥)
    dx_⊥ (trapezoidal quadrature). Cached, so the arrays are read-only."""
    z = np.linspace(0.0, h, n)
    t = np.linspace(0.0, h, n)  # |x_⊥|
    Z, T = np.meshgrid(z, t, indexing="ij")
    W, _ = cubic_values(np.sqrt(Z ** 2 + T ** 2), h, dim)
    wt = 2.0 * np.ones_like(t) if dim == 2 else 2.0 * np.pi * t  # line / ring measure
    M = np.trapezoid(W * wt, t, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (M[1:] + M[:-1]) * np.diff(z))])
    psi = cum[-1] - cum
    z.flags.writeable = psi.flags.writeable = False
    return z, psi


def _first_row(radius: float, h: float, dim: int, V0: float) -> tuple[float, float]:
    """The fluid's own share ψ_f of the first row of the rest lattice at a flat wall (rows
    at r, 3r, … from the wall surface) and its derivative ∂ψ_f/∂z along the wall normal
    (away from the wall) with the other particles held: (ψ_f, ∂ψ_f/∂z)."""
    s = 2.0 * radius
    m = int(math.ceil(h / s)) + 1
    tang = np.arange(-m, m + 1) * s
    rows = radius + s * np.arange(m + 1)
    axes = [tang, rows] + [tang] * (dim - 2)
    P = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    P[:, 1] -= radius  # relative to the first-row particle at the origin
    dist = np.linalg.norm(P, axis=1)
    W, dW = cubic_values(dist, h, dim)
    # ∂/∂z_i W(|x_i - x_j|) = W'(d) (z_i - z_j)/d = -W'(d) P_y / d
    slope = -V0 * float(np.sum(np.where(dist > 0, dW / np.maximum(dist, 1e-300), 0.0) * P[:, 1]))
    return V0 * float(W.sum()), slope


def balanced_wall(radius: float, h: float, dim: int, V0: float,
                  contact_support: float = 2.0) -> tuple[float, float]:
    """Offset δ and amplitude A of a *balanced* wall, Φ = Ψ + A Ψ_c, Ψ_c the solid's
    integral of the cubic spline of support h_c = ``contact_support`` · r (the overlap of
    the particle's own neighbourhood with the solid).

    Why: with the pressure force the negative adjoint of the compression rate, a uniform
    pressure p accelerates a fluid particle by -(p/ρ0_i)(2 ∂ψ_f/∂x + ∂Φ/∂x): the pair sum
    counts p twice (p_i + p_j), the wall once (only p_i). With Φ = Ψ (the kernel integral)
    the first row of the rest lattice gets ∂ψ_f/∂z = 0.253/r and ∂Ψ/∂z = -0.216/r (2-D;
    3-D 0.255 / -0.213), so uniform pressure pulls it into the wall with (p/ρ0) 0.29/r —
    the floor row sinks from r to ~0.35 r (docs/sph.md). A Φ that is steeper at the first
    row, ∂Φ/∂z = -2 ∂ψ_f/∂z, balances it while the force stays the adjoint of Dψ/Dt (no
    energy created, unlike a mirrored wall pressure). Two conditions on the rest lattice,
    ψ = ψ_f + Φ = 1 and that slope, fix δ (the map's surface behind the walls') and A;
    computed, not fitted, like V0 and :func:`wall_offset`. At h = 4r, h_c = 2r: δ = 0.39 r,
    A = 10.5 (2-D), 13.1 (3-D)."""
    from scipy.optimize import brentq

    psi_f, slope_f = _first_row(radius, h, dim, V0)
    z, psi = half_space_profile(h, dim, 2001)
    hc = contact_support * radius
    zc, pc = half_space_profile(hc, dim, 2001)
    dpsi, dpc = np.gradient(psi, z), np.gradient(pc, zc)

    def amplitude(off):
        z1 = radius + off
        return (-2.0 * slope_f - np.interp(z1, z, dpsi)) / np.interp(z1, zc, dpc, right=0.0)

    def residual(off):
        z1 = radius + off
        return psi_f + np.interp(z1, z, psi) + amplitude(off) * np.interp(z1, zc, pc, right=0.0) - 1.0

    plain = wall_offset(radius, h, dim, V0)
    if not hc > radius + plain:
        raise DcdcError(f"sph.wall_contact_support must exceed the first row's distance "
                        f"from the map surface (got {contact_support} r)")
    off = brentq(residual, plain, hc - radius - 1e-6 * radius)
    return float(off), float(amplitude(off))


def contact_profile(z: np.ndarray, hc: float, dim: int) -> np.ndarray:
    """Ψ_c of a flat solid at signed distance ``z`` from its surface (< 0 inside): the
    half-space integral of the kernel of support ``hc``, 1 - Ψ_c(-z) inside."""
    zt, pt = half_space_profile(hc, dim)
    z = np.asarray(z, dtype=np.float64)
    out = np.interp(np.abs(z), zt, pt, right=0.0)
    return np.where(z < 0, 1.0 - out, out)


def wall_offset(radius: float, h: float, dim: int, V0: float) -> float:
    """How far (δ) the map's solid surface lies behind the walls' surface so that the rest
    lattice touching a flat wall keeps ψ = 1: the fluid's own discrete sum over the half
    lattice (rows at r, 3r, …) exceeds the continuous integral, so the wall must supply
    Ψ = 1 - ψ_f,lattice at the first row, distance r from the wall surface; δ solves
    Ψ_half(r + δ) = 1 - ψ_f (:func:`half_space_profile`). The same consistency as the rest volume V0
    (:func:`dcdc.sph.kernels.lattice_volume`); about 0.15 r (2-D) and 0.17 r (3-D) at h = 4r."""
    need = 1.0 - _first_row(radius, h, dim, V0)[0]
    z, psi = half_space_profile(h, dim)
    if need <= 0.0:
        return h - radius
    # Ψ_half decreases with z: interpolate z(Ψ) on the reversed table
    return float(np.interp(need, psi[::-1], z[::-1])) - radius


def _grid(lo, hi, radius: float, h: float, dim: int):
    """Grid origin, cell and node counts covering [lo - h, hi + h] (plus the interpolation
    stencil); the cell is r/2 = h/8 (Ψ of the rest lattice at a flat wall within 1-2 % of
    its value on a 4x finer grid; r: 4 %), coarsened beyond MAX_NODES."""
    cell = radius / 2.0
    lo = np.asarray(lo, dtype=np.float64) - h - 2 * cell
    hi = np.asarray(hi, dtype=np.float64) + h + 2 * cell
    while True:
        shape = tuple(int(math.ceil((b - a) / cell)) + 1 for a, b in zip(lo, hi))
        if int(np.prod(shape, dtype=np.float64)) <= MAX_NODES:
            return lo, cell, shape
        cell *= 1.25


def _nodes(lo, cell, shape) -> np.ndarray:
    axes = [lo[a] + cell * np.arange(shape[a]) for a in range(len(shape))]
    return np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)


def _walls_box(wall_x: np.ndarray, lo, hi, radius: float, h: float):
    """The part of the domain [lo, hi] within h + r of the wall particles' bounding box: Ψ
    vanishes beyond it (the map returns 0 outside its grid)."""
    if not len(wall_x):
        return lo, hi
    pad = h + 2.0 * radius
    return (np.maximum(lo, wall_x.min(0) - pad), np.minimum(hi, wall_x.max(0) + pad))


def _near_walls(wall_x, g_lo, cell, shape, reach: float) -> np.ndarray:
    """Mask of the grid nodes within ``reach`` (in the max norm) of a wall particle: the
    particles' nodes dilated by a box filter, one axis at a time."""
    from scipy.ndimage import maximum_filter1d

    mask = np.zeros(shape, dtype=np.uint8)
    k = np.rint((wall_x - g_lo) / cell).astype(np.int64)
    k = np.clip(k, 0, np.asarray(shape) - 1)
    mask[tuple(k.T)] = 1
    size = 2 * int(math.ceil(reach / cell)) + 1
    for a in range(len(shape)):
        mask = maximum_filter1d(mask, size, axis=a, mode="constant")
    return mask.reshape(-1).astype(bool)


def _sdf_near_walls(sdf, wall_x, g_lo, cell, shape, reach: float):
    """The flat indices of the grid nodes within ``reach`` (max norm) of a wall particle and
    the walls' signed distance there (a one-line error for NaN/inf)."""
    idx = np.flatnonzero(_near_walls(wall_x, g_lo, cell, shape, reach))
    axes = np.unravel_index(idx, shape)
    nodes = np.stack([g_lo[a] + cell * axes[a] for a in range(len(shape))], axis=1)
    vals = np.asarray(sdf(nodes), dtype=np.float64)
    if not np.isfinite(vals).all():
        raise DcdcError("the walls' signed distance function returned NaN/inf")
    return idx, vals


def from_sdf(sdf, wall_x: np.ndarray, lo, hi, radius: float, h: float,
             offset: float = 0.0, down=None, contact=None) -> VolumeMap:
    """Volume map of the solid {sdf < -offset} (:func:`wall_offset`).
    χ = clip(1/2 - (sdf + offset) / cell, 0, 1) (the volume
    fraction of a node's cell for a locally flat surface). The SDF is evaluated only at nodes
    within ``h`` + 2 cells of a wall particle (the shell the scene sampled, at least one
    kernel support thick): elsewhere a node is fluid or deep solid that no fluid particle
    can reach within ``h``. ``contact`` = (h_c, A) of a balanced wall (:func:`balanced_wall`)."""
    dim = len(np.atleast_1d(lo))
    g_lo, cell, shape = _grid(*_walls_box(wall_x, lo, hi, radius, h), radius, h, dim)
    chi = np.zeros(shape)
    if len(wall_x):
        close, vals = _sdf_near_walls(sdf, wall_x, g_lo, cell, shape, 2.0 * radius + 2 * cell)
        chi.reshape(-1)[close] = np.clip(0.5 - (vals + offset) / cell, 0.0, 1.0)
    if contact is not None:
        # the signed distance from the map's surface on a shell reaching h_c + 3 cells into
        # the fluid (the contact's support and the interpolation stencil); beyond it h_c
        # (no contact). The FFT quadrature of χ with a kernel of support 2r (4 cells) was
        # 33 % off at the first row (measured): Ψ_c is evaluated from the distance instead
        hc, amp = contact
        dist = np.full(int(np.prod(shape)), 2.0 * hc)
        if len(wall_x):
            shell, sd = _sdf_near_walls(sdf, wall_x, g_lo, cell, shape, radius + hc + 3 * cell)
            dist[shell] = np.minimum(sd + offset, 2.0 * hc)
        contact = (dist, hc, amp)
    return VolumeMap(chi, g_lo, cell, h, down, contact)


def from_particles(wall_x: np.ndarray, lo, hi, radius: float, h: float,
                   offset: float = 0.0, down=None) -> VolumeMap:
    """Volume map of the union of the wall particles' lattice cells (cubes of side 2r),
    its exposed faces (those without a wall particle 2r beyond them) moved ``offset`` into
    the solid. The cubes tile the wall without overlap, so χ of a node is the sum over the
    nearby cubes of the fraction of the node's cell that each covers (a product of per-axis
    overlaps). Exact for walls aligned with the lattice; a staircase otherwise, which is why
    scenes hand the solver their signed distance instead (:func:`from_sdf`)."""
    dim = len(np.atleast_1d(lo))
    g_lo, cell, shape = _grid(*_walls_box(wall_x, lo, hi, radius, h), radius, h, dim)
    if not len(wall_x):
        return VolumeMap(np.zeros(shape), g_lo, cell, h, down)
    wall_x = np.ascontiguousarray(wall_x, dtype=np.float64)
    lattice = CellGrid(wall_x, 0.5 * radius)
    ext = np.empty((len(wall_x), dim, 2))  # extent of each cube towards -/+ each axis
    for a in range(dim):
        for side, sign in enumerate((-1.0, 1.0)):
            q = wall_x.copy()
            q[:, a] += sign * 2.0 * radius
            shared = lattice.search(q).counts > 0
            ext[:, a, side] = np.where(shared, radius, radius - offset)
    close = np.flatnonzero(_near_walls(wall_x, g_lo, cell, shape, radius + cell))
    axes = np.unravel_index(close, shape)
    nodes = np.stack([g_lo[a] + cell * axes[a] for a in range(dim)], axis=1)
    grid = CellGrid(wall_x, math.sqrt(dim) * (radius + cell))
    nb_ = grid.search(nodes)
    recv = nb_.receivers()
    b = nb_.index
    off = nodes[recv] - wall_x[b]  # node relative to the cube's centre
    lo_c = -ext[b, :, 0]
    hi_c = ext[b, :, 1]
    cover = np.clip(np.minimum(off + 0.5 * cell, hi_c) - np.maximum(off - 0.5 * cell, lo_c),
                    0.0, None) / cell
    frac = cover.prod(1)
    chi = np.zeros(int(np.prod(shape)))
    chi[close] = np.minimum(np.bincount(recv, weights=frac, minlength=len(nodes)), 1.0)
    return VolumeMap(chi.reshape(shape), g_lo, cell, h, down)


def for_system(sy, h: float, V0: float, buoyancy: bool = False, contact_support: float = 0.0):
    """The walls' volume map of a :class:`~dcdc.particles.ParticleSystem`: from the scene's
    signed distance function when it has one (``sy.wall_sdf``), else from the wall particles'
    lattice cells; None without walls. Its surface lies :func:`wall_offset` behind the walls'
    so that fluid at rest on the lattice next to a flat wall has ψ = 1; ``buoyancy`` adds the
    hydrostatic moment along gravity (:meth:`VolumeMap.tangential_moment`)."""
    if sy.n_wall == 0:
        return None
    lo, hi = sy.domain
    contact = None
    if contact_support > 0:
        if sy.wall_sdf is None:
            raise DcdcError("sph.wall_contact_support needs the walls' signed distance (walls "
                            "of a scene file), not wall particles alone")
        off, amp = balanced_wall(sy.radius, h, sy.dim, V0, contact_support)
        contact = (contact_support * sy.radius, amp)
    else:
        off = wall_offset(sy.radius, h, sy.dim, V0)
    g = float(np.linalg.norm(sy.gravity))
    down = sy.gravity / g if (g > 0 and buoyancy) else None
    if sy.wall_sdf is not None:
        return from_sdf(sy.wall_sdf, sy.wall_x, lo, hi, sy.radius, h, off, down, contact)
    return from_particles(sy.wall_x, lo, hi, sy.radius, h, off, down)
