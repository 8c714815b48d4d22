"""A hydrostatic reference pressure taken out of the pair-sum pressure force
(``SPHConfig.reference_density`` = ρ_ref, ``reference_level`` = L; docs/sph.md, "Why light
fluid stays under heavy fluid").

The symmetric pressure force a_i = -(1/ρ0_i)[V0 Σ_j (p_i + p_j) G_ij + β p_i S_b,i] is, for a
smooth p, ≈ -(1/ρ0_i)(∇p + 2 p_i ∇ψ_i): its level term keeps the particles ordered, and also
gives the arrangement a stiffness that grows with the pressure, i.e. with depth, so thin
layers deep under heavier fluid do not move (row ``thin_film`` of ``dcdc validate-sph``).

Split p = q + p' with the hydrostatic pressure of a reference density below a level,

    q(x) = ρ_ref |g| max(L - x·e, 0),   e = -g/|g|,

apply q through its exact gradient, a uniform body force a_i = (ρ_ref |g| / ρ0_i) e on every
particle below L, and let the pressure solves find p' >= 0 as they found p before. In the
continuum this is a gauge: -∇p/ρ0 = -∇p'/ρ0 - ∇q/ρ0 exactly, so nothing changes; discretely
the pair sum's level term sees p' = p - q only. The body force is an external potential
(energy conserving).

Where it holds: in a container without a free surface (a closed, completely filled box, any
L at or above the fluid) it is exact. With a free surface it holds only while that surface
stays at L: fluid at a free surface below L keeps the body force but not its pressure, and
floats. ρ_ref must not exceed the lightest phase's density, or p' would have to be negative
at rest where that phase lies on top (measured, 2-D full 2:1 collapse with light 500: ρ_ref
750 breaks the energy budget, +446 %; ρ_ref 1000 leaves layer purity 0.70).

Two ways of using it (docs/sph.md): closed, completely filled containers with L at the fill
height, one ρ_ref and a tenth of the damping (:func:`closed_container`, the built-in lock
exchange and hourglass), and the default for everything else: ``reference_surface``, where
L follows the lowest free-surface particle of each body of fluid (:func:`surface_levels`)
so that no surface lies below it, in open scenes too, with ``reference_stratified``, where
ρ_ref follows the layers under L (:func:`strata`).
"""
from __future__ import annotations

import numba as nb
import numpy as np


def up_and_g(gravity: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit vector against gravity and |g| (zero gravity: a zero vector and 0)."""
    g = float(np.linalg.norm(gravity))
    return (np.zeros_like(gravity) if g == 0.0 else -np.asarray(gravity) / g), g


def fill_level(x: np.ndarray, gravity: np.ndarray, r: float) -> float:
    """The default L: the top of the fluid ``x``, its highest particle centre (along -g) + r."""
    up, _ = up_and_g(gravity)
    return float((x @ up).max()) + r


AUTO_REFERENCE = 1.0
"""The default ``SPHConfig.reference_share``: with ``reference_surface`` and no
``reference_density``, ρ_ref = 1.0 × the lightest phase's density (per slab with
``reference_stratified``): the lightest phase is weightless in the pair force, and
``reference_suction`` (on by default with it) lets the solves pull, so gaps under the level
rise as a bubble does. Without suction a share below 1 (e.g. 0.9)
keeps a tenth of the weight to close those gaps, which holds thin films of light fluid under
heavy fluid (docs/sph.md, "What holds the thin film", "Closed containers")."""

SURFACE_GRADIENT = 0.75  # |∇ψ| h above this: a particle at a free surface (bulk: ~0.1)


def surface_levels(x: np.ndarray, grad_psi: np.ndarray, h: float, gravity: np.ndarray,
                   rs: np.ndarray, idx: np.ndarray, fill: float,
                   margin: float = 0.0) -> np.ndarray:
    """Per particle, the level L of its own body of fluid: the height (along -g) of that
    body's lowest particle at a free surface, less ``margin``; ``fill`` for a body without
    one (a closed, filled container). A body is a connected component of the fluid
    neighbour graph (CSR ``rs``, ``idx``: particles closer than the kernel support), so a
    few particles spilled over a glass's rim onto the table do not pull the whole glass's
    level down to the table, which switched the reference off inside the 3-D cocktail's
    glass from 2 s on (docs/sph.md, "A level per body of fluid"). A particle is at a free
    surface where its neighbourhood is one-sided, |∇ψ| h > :data:`SURFACE_GRADIENT`
    (``grad_psi`` from :func:`dcdc.sph.terms.psi_gradient`, walls counted;
    ``reference_surface``; docs/sph.md, "A level that follows the surface"). Not ψ: DFSPH
    packs a free surface's top rows to ψ ≈ 1 (measured, 2-D cocktail at 3 s: 27 of its 30
    highest particles at ψ ≥ 0.93, |∇ψ| h 0.6-1.7 there against a median of 0.09)."""
    up, _ = up_and_g(gravity)
    n_bodies, body = bodies(rs, idx)
    surf = np.sqrt((grad_psi ** 2).sum(1)) * h > SURFACE_GRADIENT
    level = np.full(n_bodies, np.inf)
    np.minimum.at(level, body[surf], x[surf] @ up - margin)
    level[np.isinf(level)] = fill
    return level[body]


@nb.njit(cache=True)
def bodies(rs: np.ndarray, idx: np.ndarray) -> tuple[int, np.ndarray]:
    """The connected components of a symmetric neighbour graph (CSR ``rs``, ``idx``):
    (their number, each node's component), by depth-first search, O(nodes + edges)
    (scipy's ``connected_components`` symmetrises the graph first: 7 ms against < 1 ms
    here for the 10 000-particle benchmark tank)."""
    n = len(rs) - 1
    body = np.full(n, -1, dtype=np.int64)
    stack = np.empty(n, dtype=np.int64)
    count = 0
    for seed in range(n):
        if body[seed] >= 0:
            continue
        body[seed] = count
        stack[0] = seed
        top = 1
        while top > 0:
            top -= 1
            i = stack[top]
            for e in range(rs[i], rs[i + 1]):
                j = idx[e]
                if body[j] < 0:
                    body[j] = count
                    stack[top] = j
                    top += 1
        count += 1
    return count, body


def strata(x: np.ndarray, rho: np.ndarray, gravity: np.ndarray, level, dz: float,
           share: float = AUTO_REFERENCE) -> np.ndarray:
    """A reference density per height, ``reference_stratified``: ``share`` × the lowest
    density ``rho`` of the particles in each slab of thickness ``dz`` below L (slab k spans
    depths [k dz, (k+1) dz) under L, ``level`` one L or one per particle, as
    :func:`surface_levels` gives; an empty slab 0).

    ``rho`` is the local column density the solver passes, the kernel mixture density of
    the neighbours, ρ̄_i = Σ_{j≠i} W_ij ρ0_j / Σ_{j≠i} W_ij
    (:func:`dcdc.sph.terms.mixture_density`), not the particles' own ρ0: a column of fluid
    at least a kernel wide filled from a height up to L holds at each height a density at
    least its slab's, so q of this profile is at most the hydrostatic pressure there and the
    solves' p' = p - q >= 0 stays reachable; a lone light
    particle or a one-particle film of it inside denser fluid, whose pressure is the denser
    fluid's, no longer sets its slab's reference to its own density (with ρ0 the oil held at
    the 3-D cocktail's glass lowered the reference of every slab it lay in and so kept
    itself there; docs/sph.md, "A level per body of fluid"). Under one heavy phase it takes
    out the heavy phase's level, where a constant ρ_ref <= the lightest density leaves most
    of it (row ``thin_film``; docs/sph.md, "A reference that follows the layers")."""
    _, _, depth = _depth(x, gravity, level)
    below = depth > 0
    k = (depth[below] / dz).astype(np.int64)
    profile = np.full(int(k.max()) + 1 if below.any() else 1, np.inf)
    np.minimum.at(profile, k, rho[below])
    return share * fill_aliased_slabs(profile)


def fill_aliased_slabs(profile: np.ndarray) -> np.ndarray:
    """The slab profile with each empty slab (``inf``) that lies between two occupied ones
    set to the lower of their two densities, and the empty slabs above the first occupied
    one set to 0.

    The slabs are one particle diameter thick, the spacing of the rows of a packing, so a
    row that sits on a slab face leaves a slab empty and puts two rows in the next one; as
    the rows move by a fraction of a spacing such a gap opens and closes from substep to
    substep. Left at 0, each one would drop |g| ρ_ref d from the q below it (13
    of 39 slabs in the 2-D tank at rest's first substep, measured). Only q, the reported pressure's
    reference part, depends on it: the reference force acts on particles, and no particle
    lies in an empty slab. A slab inside a column of fluid is not empty of fluid, only of
    particle centres (docs/sph.md, "Aliased slabs")."""
    filled = profile.copy()
    occupied = np.isfinite(profile)
    if not occupied.any():
        return np.zeros_like(profile)
    k = np.arange(len(profile))
    above = np.maximum.accumulate(np.where(occupied, k, -1))  # nearest occupied at or above
    below = np.minimum.accumulate(np.where(occupied, k, len(k))[::-1])[::-1]
    inner = ~occupied & (above >= 0) & (below < len(k))
    filled[inner] = np.minimum(profile[above[inner]], profile[below[inner]])
    filled[~occupied & ~inner] = 0.0
    return filled


def _depth(x: np.ndarray, gravity: np.ndarray, level):
    """(e, |g|, the depth of each x under L (one level, or one per x), 0 above it)."""
    up, g = up_and_g(gravity)
    return up, g, np.maximum(level - x @ up, 0.0)


def _slab(depth: np.ndarray, profile: np.ndarray, dz: float) -> np.ndarray:
    """The slab of :func:`strata` each depth lies in (below the deepest: the deepest; a NaN
    depth, a state gone NaN that the substep's check then reports, slab 0)."""
    k = np.nan_to_num(np.floor(depth / dz), nan=0.0)
    return np.minimum(k, len(profile) - 1).astype(np.int64)


def reference_pressure(x: np.ndarray, gravity: np.ndarray, rho_ref, level: float,
                       dz: float = 0.0) -> np.ndarray:
    """q_i = |g| ∫ ρ_ref over the depths from L down to x_i [Pa]: ρ_ref |g| max(L - x_i·e, 0)
    for a constant ρ_ref (``dz`` 0); ``dz`` > 0: ρ_ref is the slab profile of :func:`strata`."""
    _, g, depth = _depth(x, gravity, level)
    return _pressure_at(depth, g, rho_ref, dz)


def _pressure_at(depth: np.ndarray, g: float, rho_ref, dz: float) -> np.ndarray:
    """q at the given depths under L (:func:`reference_pressure`)."""
    if dz == 0.0:
        return rho_ref * g * depth
    k = _slab(depth, rho_ref, dz)
    above = np.concatenate(([0.0], np.cumsum(rho_ref * dz)))[k]  # the slabs over slab k
    return g * (above + rho_ref[k] * (depth - k * dz))


def covered_pressure(x: np.ndarray, gravity: np.ndarray, rho_ref, level, dz: float,
                     margin: float) -> np.ndarray:
    """q_i of :func:`reference_pressure` where x_i lies more than ``margin`` under the level,
    0 elsewhere (``reference_suction``: the particles whose solve may go down to p' = -q)."""
    _, g, depth = _depth(x, gravity, level)
    return np.where(depth > margin, _pressure_at(depth, g, rho_ref, dz), 0.0)


def reference_acceleration(x: np.ndarray, gravity: np.ndarray, rho0: np.ndarray,
                           rho_ref, level: float, dz: float = 0.0) -> np.ndarray:
    """-∇q/ρ0_i = (ρ_ref(x_i) |g| / ρ0_i) e below L, 0 above [m/s²]."""
    up, g, depth = _depth(x, gravity, level)
    rho = rho_ref if dz == 0.0 else rho_ref[_slab(depth, rho_ref, dz)]
    return ((depth > 0) * rho * g / rho0)[:, None] * up[None, :]


CLOSED_DAMPING = {"xsph": 0.01, "viscosity": 1e-4}
"""XSPH strength and artificial viscosity [m²/s] of closed containers: a tenth of the defaults.
With the reference the packing of a closed, filled two-layer tank at rest needs no more
(2-D, r = 10 mm, 3 s: mean speed 1.0 % of sqrt(gH) at the end, against 1.3 % with the
defaults and no reference; ``benchmarks/closed_containers.py``), and halving it changes the
lock exchange's heavy front by 3 % at 5 mm (docs/sph.md, "Closed containers"). The built-in ``lock_exchange`` and ``hourglass`` scenes set these values."""


def closed_container(settings: dict, rho_ref: float) -> dict:
    """Solver ``settings`` for a closed container: the hydrostatic reference of density
    ``rho_ref`` (the lightest phase's at most, one for the whole container) fixed at the
    fill height, and :data:`CLOSED_DAMPING`; the other reference options off."""
    return {**settings, "reference_density": float(rho_ref), "reference_level": None,
            "reference_surface": False, "reference_stratified": False, **CLOSED_DAMPING}
