"""Divergence-free SPH (Bender & Koschier 2015, "Divergence-free smoothed particle
hydrodynamics", Alg. 1) on the number-density, volume-symmetric multiphase formulation.

One substep of length Δt:
1. divergence-free solve: pressures p_div >= 0 with  Dψ/Dt(v + Δt a(p_div)) = 0  where the
   flow compresses (particles with a full neighbourhood only, as in DFSPH);
2. non-pressure forces: v* = v + Δt (g + viscosity + cohesion + interfacial tension), plus
   the force of the optional uniform background pressure p_b (``SPHConfig.background_pressure``,
   :func:`dcdc.sph.terms.background_acceleration`): a constant part of the pressure force,
   applied here so that the constant-density solve below sees (and corrects) any compression
   it causes; the solves themselves and the reported pressure are unchanged;
3. constant-density solve: pressures p >= 0 with  ψ + Δt Dψ/Dt(v* + Δt a(p)) = ψ_target,
   ψ_target = max(1, ψ - Δt u_c/2r): new compression is stopped in full, a density error
   already present is removed at most at the rate u_c/2r (``SPHConfig.correction_speed``);
   with ``SPHConfig.reference_suction`` the bound is p + q >= 0 (q the hydrostatic reference,
   :mod:`dcdc.sph.reference`) instead of p >= 0 for the particles a diameter under its
   level (docs/sph.md, "What holds the thin film");
4. v = v* + Δt a(p),  x += Δt v  (then the walls' contact, :meth:`VolumeMap.keep_outside`).

Both solves are the same linear complementarity problem A p = s, p >= 0, where A is the map
p -> Dψ/Dt(a(p)) of :mod:`dcdc.sph.terms`, solved by relaxed Jacobi with the exact diagonal
(as IISPH, Ihmsen et al. 2014, eq. 13) and warm-started from the previous substep (DFSPH
§4). Because a(p) is built from volumes, not masses, a light particle next to a heavy one
gets a large diagonal 1/ρ0 and the iteration stays contractive at 10:1 (docs/sph.md).
"""
from __future__ import annotations

import numpy as np

from . import pcg
from .config import SPHConfig
from .forces import non_pressure_acceleration, smooth_velocity
from .neighbourhood import Neighbourhood
from .reference import covered_pressure
from .state import State
from .terms import compression_rate, jacobi_update, pressure_acceleration, pressure_diagonal

# DFSPH skips the divergence solve for particles with a sparse neighbourhood (Bender &
# Koschier 2017, SPlisHSPlasH TimeStepDFSPH: 20 neighbours in 3-D), scaled to 2-D.
MIN_NEIGHBOURS = {2: 7, 3: 20}
# a particle whose compression ψ is this far below 1 counts as free surface / spray
SURFACE_GAP = 0.01
# The solves stop when the mean residual is below the tolerance *and* the largest is below
# MAX_TO_MEAN × tolerance. The mean alone is blind to a residual concentrated in one layer
# (the particles on a floor under a deep or heavy column: 1 row of 40 in a tank); measured,
# light particles under a 3000 kg/m³ layer were then pressed into the floor and exploded.
MAX_TO_MEAN = 10.0
WALL_MIRROR = 1.0  # β of terms.py: 1 keeps the pressure operator the adjoint of Dψ/Dt


def _acceleration(s: State, nbh: Neighbourhood, p: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The pressure acceleration a(p) (written to ``a``)."""
    return pressure_acceleration(p, s.rho0, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0, a,
                                 WALL_MIRROR)


def _apply(s: State, nbh: Neighbourhood, p: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(A p)_i = Dψ_i/Dt of the pressure acceleration a(p) (written to ``a``)."""
    return compression_rate(_acceleration(s, nbh, p, a), nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0,
                            WALL_MIRROR)


def pressure_solve(s: State, nbh: Neighbourhood, p: np.ndarray, base: np.ndarray, coef: float,
                   target: float, mask: np.ndarray, tol: float, diag: np.ndarray,
                   cfg: SPHConfig) -> tuple[int, float, np.ndarray]:
    """Solve base + coef·A p = target for p >= 0 in place (p = 0 outside ``mask``).

    First, Jacobi-preconditioned conjugate gradients on the particles of ``mask`` (-A is
    symmetric positive definite there: Σ_i q_i (A p)_i = -F(q)·M⁻¹F(p) / V0), warm-started
    from ``p``; pressure propagates through a column of n particles in O(n) iterations
    instead of Jacobi's O(n²). Then clamp p >= 0 and polish the complementarity
    (free surface, separating particles) with relaxed Jacobi sweeps (IISPH eq. 13).
    Stops when the mean residual |base + coef·A p - target| over ``mask`` is below ``tol``
    and the largest below MAX_TO_MEAN·``tol``.

    Returns (matrix-vector products, mean residual, pressure acceleration a(p))."""
    a = np.empty_like(s.v)
    n_mask = max(int(mask.sum()), 1)
    p[~mask] = 0.0
    rhs = (target - base) / coef
    minv = pcg.preconditioner(diag, mask)
    r = np.empty_like(p)
    z = np.empty_like(p)
    d = np.empty_like(p)
    # CG on (-A) p = -rhs restricted to mask
    sa, mx, rz = pcg.init(_apply(s, nbh, p, a), rhs, mask, minv, r, z, d)
    it = 1
    err = coef * max(sa / n_mask, mx / MAX_TO_MEAN)
    while err > tol and it < cfg.max_iterations and rz > 0.0:
        Ad = _apply(s, nbh, d, a)
        dAd = pcg.negate_masked_dot(Ad, d, mask)
        if dAd <= 0.0:
            break
        sa, mx, rz_new = pcg.step(p, r, d, Ad, minv, rz / dAd)
        it += 1
        err = coef * max(sa / n_mask, mx / MAX_TO_MEAN)
        pcg.direction(d, r, minv, rz_new / rz)
        rz = rz_new
    np.maximum(p, 0.0, out=p)
    for _ in range(cfg.min_iterations):
        Ap = _apply(s, nbh, p, a)
        err = jacobi_update(p, base, Ap, diag, coef, target, mask, cfg.omega)
        it += 1
    _acceleration(s, nbh, p, a)
    return it, err, a


def substep(s: State, nbh: Neighbourhood, dt: float, cfg: SPHConfig) -> dict:
    """Advance ``s`` by ``dt`` in place; returns iteration counts and solver errors."""
    diag = pressure_diagonal(s.rho0, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0, WALL_MIRROR)
    it_div, err_div = 0, 0.0
    # Particles at a free surface or in spray (sparse neighbourhood, or clearly expanded) are
    # left free (p = 0); inside, compression *and* expansion are corrected, so a fluid that
    # opened a gap recloses it instead of keeping it (negative pressures are clamped after).
    full = nbh.counts >= MIN_NEIGHBOURS[s.dim]
    if cfg.divergence_solve:
        rate = compression_rate(s.v, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0, WALL_MIRROR)
        mask = full & (nbh.psi >= 1.0 - SURFACE_GAP)
        it_div, err_div, a = pressure_solve(s, nbh, s.p_div, rate, dt, 0.0, mask,
                                            cfg.divergence_tolerance / dt, diag, cfg)
        s.v += dt * a
    s.v += dt * non_pressure_acceleration(s, nbh, cfg.no_slip, cfg.surface_tension,
                                          cfg.background_pressure)
    smooth_velocity(s, nbh, cfg.xsph)
    rate = compression_rate(s.v, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0, WALL_MIRROR)
    psi_star = nbh.psi + dt * rate
    mask = full & (psi_star >= 1.0 - SURFACE_GAP)
    base = psi_star
    diameter = 2.0 * s.h / cfg.support
    if cfg.correction_speed > 0:
        # the density error already present is removed at most at the rate u_c / 2r per
        # second (target max(1, ψ - Δt u_c/2r)); new compression is still stopped in full
        slack = np.maximum(nbh.psi - 1.0 - dt * cfg.correction_speed / diameter, 0.0)
        base = psi_star - slack
    suction = cfg.reference_suction and s.reference is not None
    if suction:
        # solve for p' + q >= 0 (total pressure >= 0) instead of p' >= 0, for the solve's
        # particles a diameter under the level (expanded ones stay out: with them, the first
        # form, the walls' ψ deficits at a closed box's corners entered with the target ψ = 1
        # and the lock exchange blew up; docs/sph.md, "What holds the thin film"): the
        # right-hand side shifted by the operator applied to q, the warm start by q, the
        # acceleration of q taken off
        q = np.where(mask, covered_pressure(s.x, s.gravity, *s.reference, margin=diameter), 0.0)
        a_q = np.empty_like(s.v)
        base = base - dt * dt * _apply(s, nbh, q, a_q)
        s.p += q
    it, err, a = pressure_solve(s, nbh, s.p, base, dt * dt, 1.0, mask,
                                cfg.density_tolerance, diag, cfg)
    if suction:
        s.p -= q
        a -= a_q
    s.v += dt * a
    s.x += dt * s.v
    return {"iterations": it, "divergence_iterations": it_div, "solver_error": err,
            "divergence_error": err_div * dt}
