"""Measurements of a particle state — arrays in, numbers out (definitions in docs/evaluation.md).

The one definition of every physical and error metric the project reports, shared by the
SPH validation (``dcdc validate-sph``), the demo and the evaluation of learned models
(``dcdc evaluate``). Definitions with formulas: docs/evaluation.md.

Conventions: positions ``x`` are [N, d] (y, index 1, is up unless ``up`` says otherwise),
``phase`` is the int phase index [N]; a boolean ``active`` mask [N] (particles already
born, see :class:`dcdc.particles.ParticleSystem`) restricts a metric where given. Lengths
come back in the units they went in (metres); the evaluation converts to mm.

This module imports numpy only; the neighbour search (:mod:`dcdc.neighbors`), scipy's
k-d tree, scipy.stats and POT (optimal transport) are imported inside the functions that need them.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "phase_heights", "phase_order_ok", "density_order_ok", "ideal_layer_purity",
    "neighbour_purity", "same_phase_fraction", "phase_volumes", "volume_error",
    "density_error", "kinetic_energy", "momentum", "position_error", "nearest_error",
    "wasserstein_distance", "height_distance", "column_depth",
    "layers_like", "neighbour_purity_per_phase", "inside_walls", "wall_penetrations",
]


def _select(mask, *arrays):
    if mask is None:
        return arrays
    m = np.asarray(mask, dtype=bool)
    return tuple(np.asarray(a)[m] for a in arrays)


# ---------------------------------------------------------------------------- stratification
def phase_heights(x, phase, n_phases: int | None = None, stat: str = "mean", up: int = 1,
                  active=None) -> np.ndarray:
    """Height of each phase [P]: the mean (centre of mass at equal particle volumes) or the
    median of its particles' ``up`` coordinate; NaN for a phase without (active) particles.

    The median says where the bulk of a phase sits; the mean (centre of mass) is dragged by
    the few droplets a phase leaves trapped under the others (docs/evaluation.md)."""
    if stat not in ("mean", "median"):
        raise ValueError(f"stat must be 'mean' or 'median' (got {stat!r})")
    x, phase = _select(active, np.asarray(x), np.asarray(phase))
    P = int(n_phases if n_phases is not None else (phase.max() + 1 if len(phase) else 0))
    out = np.full(P, np.nan)
    f = np.mean if stat == "mean" else np.median
    for k in range(P):
        sel = phase == k
        if sel.any():
            out[k] = float(f(x[sel, up]))
    return out


def phase_order_ok(x, phase, order_bottom_to_top: Sequence[int], stat: str = "mean",
                   up: int = 1, active=None) -> bool:
    """True when the phases listed bottom to top have strictly increasing heights
    (:func:`phase_heights`; the validation's "heavy below" check, mean heights)."""
    h = phase_heights(x, phase, max(order_bottom_to_top, default=-1) + 1, stat, up, active)
    ys = [h[k] for k in order_bottom_to_top]
    return bool(all(a < b for a, b in zip(ys, ys[1:])))


def density_order_ok(x, phase, phase_densities, stat: str = "median", up: int = 1,
                     active=None) -> bool:
    """Stable stratification: every phase lies strictly below every lighter phase.

    Phases are ranked by rest density; empty phases are skipped and phases of equal
    density are not compared. Default statistic: the median height (as the demo reports)."""
    rho = np.asarray(phase_densities, dtype=np.float64)
    h = phase_heights(x, phase, len(rho), stat, up, active)
    ks = [k for k in range(len(rho)) if np.isfinite(h[k])]
    # every pair: with equal densities a chain of neighbours in density order would skip some
    return all(h[a] < h[b] for a in ks for b in ks if rho[a] > rho[b])


def ideal_layer_purity(x, phase, order_bottom_to_top: Sequence[int], floor: float,
                       area: float, volume: float, spacing: float, up: int = 1) -> float:
    """Fraction of all fluid particles lying in their phase's ideal layer (± one spacing).

    The layers are stacked from ``floor`` in the given order with heights N_k·V / area
    (N_k particles of phase k, ``volume`` V per particle, ``area`` the tank's floor area,
    its width in 2-D); a particle of phase k counts when its height lies in
    [base_k − spacing, base_k + N_k V/area + spacing]. Particles of phases not listed count
    in the total but never as in place. Used by the SPH validation's closed-tank cases."""
    x, phase = np.asarray(x), np.asarray(phase)
    n = len(phase)
    if n == 0:
        return float("nan")
    y = x[:, up]
    ok = 0
    base = float(floor)
    for k in order_bottom_to_top:
        m = phase == k
        hgt = m.sum() * volume / area
        lo, hi = base - spacing, base + hgt + spacing
        ok += int(((y[m] >= lo) & (y[m] <= hi)).sum())
        base += hgt
    return ok / n


def same_phase_fraction(x, phase, radius: float) -> np.ndarray:
    """Per particle, the fraction of its neighbours within ``radius`` (self excluded) that
    belong to its own phase; NaN for a particle without neighbours."""
    from .neighbors import radius_search

    nb = radius_search(x, radius, exclude_self=True)
    rec = nb.receivers()
    same = np.bincount(rec, weights=(phase[rec] == phase[nb.index]).astype(np.float64),
                       minlength=len(x))
    counts = nb.counts
    return np.where(counts > 0, same / np.maximum(counts, 1), np.nan)


def neighbour_purity(x, phase, radius: float, active=None) -> float:
    """Interface sharpness: the mean over particles with at least one neighbour within
    ``radius`` of the fraction of those neighbours that belong to the particle's own phase
    (1 = perfectly separated phases; a well-mixed two-phase 1:1 state gives ≈ 0.5)."""
    x, phase = _select(active, np.asarray(x, dtype=np.float64), np.asarray(phase))
    if len(x) < 2:
        return float("nan")
    frac = same_phase_fraction(x, phase, radius)
    return float(np.nanmean(frac)) if np.isfinite(frac).any() else float("nan")


def neighbour_purity_per_phase(x, phase, radius: float, n_phases: int) -> np.ndarray:
    """:func:`neighbour_purity` of each phase separately [P] (the layer purity of a showcase
    whose layers are not flat, e.g. a glass): per phase, the mean over its particles of the
    fraction of their neighbours within ``radius`` of the same phase."""
    x = np.asarray(x, dtype=np.float64)
    phase = np.asarray(phase)
    frac = same_phase_fraction(x, phase, radius)
    return np.array([np.nanmean(frac[phase == k]) if (phase == k).any() else np.nan
                     for k in range(n_phases)])


def trapped_at_walls(x, phase, phase_densities, wall_x, radius: float) -> np.ndarray:
    """Fraction of each phase [P] held at a wall under denser fluid: particles within two
    spacings (4r) of a wall particle most of whose fluid neighbours (within 2.5r) belong to
    denser phases whose mean height is above the particle (light fluid glued to a glass
    under a heavier layer; a light particle resting on a denser layer is not counted).
    Heights along axis 1 (y up)."""
    from .neighbors import radius_search

    x = np.asarray(x, dtype=np.float64)
    phase = np.asarray(phase)
    dens = np.asarray(phase_densities, dtype=np.float64)
    nb = radius_search(x, 2.5 * radius, exclude_self=True)
    rec = nb.receivers()
    is_denser = (dens[phase[nb.index]] > dens[phase[rec]]).astype(np.float64)
    denser = np.bincount(rec, weights=is_denser, minlength=len(x))
    frac = denser / np.maximum(nb.counts, 1)
    dy = np.bincount(rec, weights=is_denser * (x[nb.index, 1] - x[rec, 1]), minlength=len(x))
    above = dy > 0.0  # the denser neighbours lie above on average
    at_wall = radius_search(x, 4.0 * radius, np.asarray(wall_x, dtype=np.float64)).counts > 0
    held = at_wall & (frac > 0.5) & above
    return np.array([held[phase == k].mean() if (phase == k).any() else 0.0
                     for k in range(len(dens))])


def layer_summary(x, phase, phase_densities, wall_x, radius: float) -> dict:
    """A layered showcase's state in one call (the cocktail's checks): ``order``
    (:func:`density_order_ok`), ``purity`` per phase (:func:`neighbour_purity_per_phase`
    within 2.5 r) and ``trapped``, each phase's share held at the walls under denser fluid
    (:func:`trapped_at_walls`)."""
    dens = np.asarray(phase_densities, dtype=np.float64)
    return {"order": bool(density_order_ok(x, phase, dens)),
            "purity": neighbour_purity_per_phase(x, phase, 2.5 * radius, len(dens)),
            "trapped": trapped_at_walls(x, phase, dens, wall_x, radius)}


def _column_search(x, points, half_width: float, up: int):
    """Pairs (x_i, points_j) in the same vertical column: horizontal distance <= half_width."""
    from .neighbors import radius_search

    h = np.delete(np.asarray(x, dtype=np.float64), up, axis=1)
    hp = np.delete(np.asarray(points, dtype=np.float64), up, axis=1)
    if h.shape[1] == 1:  # 2-D: one horizontal axis, padded for the 2|3-D search
        h, hp = np.pad(h, ((0, 0), (0, 1))), np.pad(hp, ((0, 0), (0, 1)))
    return radius_search(h, half_width, hp)


def pooled_heavy(x, phase, phase_densities, wall_x, radius: float, up: int = 1,
                 depth_rows: int = 3) -> tuple[float, float]:
    """Does the densest phase collect in the depressions of uneven ground (the canyon)?

    Per particle i: its floor f_i, the highest wall particle below it within a column of
    half-width 2r, and the depth of fluid there, the highest fluid particle of that column
    minus f_i. A particle is *pooled* where that depth is at least ``depth_rows`` spacings
    (a basin or the pool at a downstream wall, not a film running down a slope). A pooled
    particle is *inverted* if a particle of a lighter phase lies more than r below it in its
    column of half-width r. Returns (share of the densest phase's particles that are pooled,
    share of the pooled particles that are inverted): 1 and 0 when the heavy liquid has
    gathered in the basins under the lighter ones. Heights along axis ``up``."""
    x = np.asarray(x, dtype=np.float64)
    phase = np.asarray(phase)
    dens = np.asarray(phase_densities, dtype=np.float64)
    wall_x = np.asarray(wall_x, dtype=np.float64)
    nb = _column_search(x, wall_x, 2.0 * radius, up)
    rec, yb = nb.receivers(), wall_x[nb.index, up]
    below = yb < x[rec, up]
    floor = np.full(len(x), -np.inf)
    np.maximum.at(floor, rec[below], yb[below])
    nf = _column_search(x, x, 2.0 * radius, up)
    top = np.full(len(x), -np.inf)
    np.maximum.at(top, nf.receivers(), x[nf.index, up])
    pooled = np.isfinite(floor) & (top - floor >= depth_rows * 2.0 * radius)
    nn = _column_search(x, x, radius, up)
    ri, rj = nn.receivers(), nn.index
    under_lighter = (x[rj, up] < x[ri, up] - radius) & (dens[phase[rj]] < dens[phase[ri]])
    inverted = np.zeros(len(x), dtype=bool)
    inverted[ri[under_lighter]] = True
    is_heavy = phase == int(np.argmax(dens))
    pooled_share = float(pooled[is_heavy].mean()) if is_heavy.any() else 0.0
    inverted_share = float(inverted[pooled].mean()) if pooled.any() else 0.0
    return pooled_share, inverted_share


# ---------------------------------------------------------------------------- volume / density
def phase_volumes(psi, phase, volume: float, n_phases: int | None = None) -> np.ndarray:
    """Volume per phase V_k = Σ_{i∈k} V / max(ψ_i, 1) [P] from the number density ψ_i = ρ_i/ρ0_i.

    Compression (ψ > 1) shrinks a phase; the kernel deficiency at a free surface (ψ < 1) is
    not counted as expansion. Inactive particles carry ψ = NaN and are left out."""
    psi, phase = np.asarray(psi, dtype=np.float64), np.asarray(phase)
    P = int(n_phases if n_phases is not None else (phase.max() + 1 if len(phase) else 0))
    ok = np.isfinite(psi)
    vol = volume / np.maximum(psi[ok], 1.0)
    return np.bincount(phase[ok], weights=vol, minlength=P)


def volume_error(volumes, reference) -> np.ndarray:
    """Relative volume change per phase (V_k − V_k,ref) / V_k,ref; NaN where V_k,ref = 0."""
    v, r = np.asarray(volumes, dtype=np.float64), np.asarray(reference, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 0, (v - r) / r, np.nan)


def density_error(psi) -> float:
    """Mean compression mean_i max(ψ_i − 1, 0) (the SPH solver's density error; NaN = inactive)."""
    psi = np.asarray(psi, dtype=np.float64)
    psi = psi[np.isfinite(psi)]
    return float(np.maximum(psi - 1.0, 0.0).mean()) if len(psi) else float("nan")


# ---------------------------------------------------------------------------- energy / momentum
def kinetic_energy(v, mass) -> float:
    """KE = ½ Σ_i m_i |v_i|² [J]."""
    v, m = np.asarray(v, dtype=np.float64), np.asarray(mass, dtype=np.float64)
    return 0.5 * float(m @ (v ** 2).sum(1)) if len(v) else 0.0


def momentum(v, mass) -> np.ndarray:
    """Linear momentum P = Σ_i m_i v_i [d] (kg m/s)."""
    v, m = np.asarray(v, dtype=np.float64), np.asarray(mass, dtype=np.float64)
    return m @ v if len(v) else np.zeros(v.shape[1] if v.ndim == 2 else 0)


# ---------------------------------------------------------------------------- errors vs truth
def position_error(pred, true, active=None) -> float:
    """Mean per-particle Euclidean distance mean_i |x̂_i − x_i| between matched particles
    (DeepLagrangianFluids' n+1 / n+2 error); NaN if a prediction is not finite."""
    pred, true = _select(active, np.asarray(pred, np.float64), np.asarray(true, np.float64))
    if len(pred) == 0:
        return float("nan")
    if not np.isfinite(pred).all():
        return float("nan")
    return float(np.linalg.norm(pred - true, axis=1).mean())


def nearest_error(pred, true) -> float:
    """Mean over true particles of the distance to the nearest predicted particle
    (DeepLagrangianFluids' whole-sequence "gt2pred" error; identity-free)."""
    from scipy.spatial import cKDTree

    pred, true = np.asarray(pred, np.float64), np.asarray(true, np.float64)
    if len(true) == 0 or len(pred) == 0 or not np.isfinite(pred).all():
        return float("nan")
    dist, _ = cKDTree(pred).query(true)
    return float(dist.mean())


def _subsample(a, b, max_points: int, seed: int):
    """``a`` and ``b`` cut to at most ``max_points`` rows (fixed ``seed``). Clouds of equal
    size keep the same rows of both: a rollout and its ground truth list the same particles
    in the same order, and independent subsets of one cloud would be a distance apart
    (sampling noise) that no model error made."""
    rng = np.random.default_rng(seed)
    if len(a) == len(b):
        if len(a) > max_points:
            keep = rng.choice(len(a), max_points, replace=False)
            a, b = a[keep], b[keep]
        return a, b
    if len(a) > max_points:
        a = a[rng.choice(len(a), max_points, replace=False)]
    if len(b) > max_points:
        b = b[rng.choice(len(b), max_points, replace=False)]
    return a, b


def wasserstein_distance(a, b, max_points: int = 2000, seed: int = 0) -> float:
    """2-Wasserstein distance between two point clouds [length], exact.

    W₂(a, b) = sqrt(min_π Σ_ij π_ij ‖a_i − b_j‖²) over transport plans π with uniform
    marginals (1/|a|, 1/|b|), solved exactly by POT's network simplex (``ot.emd2``,
    Flamary et al. 2021). Unlike an entropic (Sinkhorn) estimate it has no blur bias and no
    regularisation that can underflow: a cloud shifted by s is at distance s for any size.
    It ignores which particle is which (a swap of two particles costs nothing). Clouds larger
    than ``max_points`` are subsampled (:func:`_subsample`; exact OT costs O(n³) in the worst
    case: 2 000 points take about 1.5 s). NaN for an empty or non-finite cloud."""
    import ot

    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        return float("nan")
    a, b = _subsample(a, b, max_points, seed)
    cost = float(ot.emd2([], [], ot.dist(a, b), numItermax=10_000_000))
    return float(np.sqrt(max(cost, 0.0)))


# ---------------------------------------------------------------------------- mixing
def height_distance(x, phase, x_ref, phase_ref, n_phases: int, up: int = 1) -> np.ndarray:
    """Per phase [P], the 1-Wasserstein distance between the distributions of its particles'
    heights in ``x`` and in the reference ``x_ref`` [length]:
    W₁ = ∫ |F_k(h) − F_k^ref(h)| dh (F: the empirical distribution functions of the heights,
    ``scipy.stats.wasserstein_distance``). A phase in the same layer as the reference scores
    ≈ 0; one spread over the column instead of in its layer scores about a quarter of the
    column (what the centre-of-mass height cannot see: a phase mixed evenly through the
    column keeps its centre of mass). NaN for a phase absent from either state."""
    from scipy.stats import wasserstein_distance as w1

    x, x_ref = np.asarray(x, np.float64), np.asarray(x_ref, np.float64)
    phase, phase_ref = np.asarray(phase), np.asarray(phase_ref)
    out = np.full(n_phases, np.nan)
    for k in range(n_phases):
        h, h_ref = x[phase == k, up], x_ref[phase_ref == k, up]
        if len(h) and len(h_ref) and np.isfinite(h).all() and np.isfinite(h_ref).all():
            out[k] = float(w1(h, h_ref))
    return out


def column_depth(x, up: int = 1) -> float:
    """The height range of a fluid state, max − min of its ``up`` coordinates [length]: the
    scale that :func:`height_distance` is judged against."""
    h = np.asarray(x, np.float64)[:, up]
    h = h[np.isfinite(h)]
    return float(h.max() - h.min()) if len(h) else float("nan")


PURITY_RATIO = 0.9  # layers_like: each phase's purity at least this fraction of the reference's
HEIGHT_FRACTION = 0.05  # layers_like: each phase's height distance at most this fraction of the column


def layers_like(purity, purity_ref, height_dist, depth: float,
                purity_ratio: float = PURITY_RATIO, height_fraction: float = HEIGHT_FRACTION) -> bool:
    """The verdict "layered like the reference" of one state: every phase's neighbour purity
    is at least ``purity_ratio`` × the reference's (:func:`neighbour_purity_per_phase`) and
    every phase's height distribution is within ``height_fraction`` × the reference column's
    depth of the reference's (:func:`height_distance`, :func:`column_depth`). Phases absent
    from either state (NaN) are skipped; False when no phase can be compared."""
    purity, purity_ref = np.asarray(purity, float), np.asarray(purity_ref, float)
    height_dist = np.asarray(height_dist, float)
    ok_p = np.isfinite(purity) & np.isfinite(purity_ref)
    ok_h = np.isfinite(height_dist)
    if not (ok_p.any() and ok_h.any()) or not np.isfinite(depth):
        return False
    return bool((purity[ok_p] >= purity_ratio * purity_ref[ok_p]).all()
                and (height_dist[ok_h] <= height_fraction * depth).all())


# ---------------------------------------------------------------------------- walls
FACING_COS = 0.866  # wall particles whose normals lie within 30° count as one face


def inside_walls(x, wall_x, wall_n, spacing: float, grid=None) -> np.ndarray:
    """Boolean mask [N]: fluid particles inside a wall — behind a wall particle b within a
    spacing by more than a quarter spacing, ``(x − x_b)·n_b < −spacing/4`` (normals point
    into the fluid), where b faces the same way as the particle's nearest wall particle
    (normals within 30°, :data:`FACING_COS`).

    The facing condition keeps convex corners (a glass's rim, an hourglass's neck) apart: a
    particle in front of the nearest face can lie behind the plane of a particle on the other
    face, also where the faces meet at a shallow angle (the hourglass's funnel meets its
    vertical neck at 38°: a particle a radius in front of the funnel, just above the neck's
    top, lies r/2 behind the plane of the neck's first wall particle). Closeness alone is
    not a penetration: the SPH data keeps its first row at the wall particles (on the suite's glasses and hourglasses up to 1 % of the fluid comes within a
    quarter spacing of one, in front of it) and never behind them.

    ``grid``: a :class:`~dcdc.neighbors.CellGrid` of ``wall_x`` built with :func:`wall_grid`
    (walls do not move: a rollout builds it once instead of every step); same result."""
    from .neighbors import nearest_values

    x = np.asarray(x, dtype=np.float64)
    out = np.zeros(len(x), dtype=bool)
    wall_x = np.asarray(wall_x, dtype=np.float64)
    if len(x) == 0 or len(wall_x) == 0:
        return out
    finite = np.isfinite(x).all(1)
    xf = x[finite]
    nb = (grid if grid is not None else wall_grid(wall_x, spacing)).search(xf)
    if nb.n_edges == 0:
        return out
    wall_n = np.asarray(wall_n, dtype=np.float64)
    recv = nb.receivers()
    off = xf[recv] - wall_x[nb.index]
    dist = np.linalg.norm(off, axis=1)
    n = wall_n[nb.index]
    nearest_n = nearest_values(recv, dist, n, len(xf))
    side = np.einsum("ij,ij->i", off, n)
    facing = np.einsum("ij,ij->i", n, nearest_n[recv]) > FACING_COS
    bad = np.unique(recv[facing & (side < -0.25 * spacing)])
    out[np.flatnonzero(finite)[bad]] = True
    return out


def wall_grid(wall_x, spacing: float):
    """The cell list :func:`inside_walls` searches, for walls that stay where they are."""
    from .neighbors import CellGrid

    return CellGrid(np.asarray(wall_x, dtype=np.float64), spacing * (1 + 1e-6))


def wall_penetrations(x, wall_x, wall_n, spacing: float) -> int:
    """Number of fluid particles inside a wall (:func:`inside_walls`)."""
    return int(inside_walls(x, wall_x, wall_n, spacing).sum())
