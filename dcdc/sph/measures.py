"""Measurements of the SPH validation (:mod:`dcdc.sph.cases`): a table row, layers and
volumes, energy, speeds over a run, fronts of a surge and of a lock exchange, the closest
particle pair, a drop's radius and contact angle, and the extrapolation of a quantity to
r -> 0."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import metrics
from ..particles import FRAME_DT, ParticleSystem
from .solver import Simulator


@dataclass
class Row:
    """One line of the table; ``passed`` is None for an information row (no check)."""

    case: str
    quantity: str
    measured: float
    reference: str
    tolerance: str
    passed: bool | None

    @property
    def failed(self) -> bool:
        return self.passed is False

    def as_dict(self) -> dict:
        return {"case": self.case, "quantity": self.quantity, "measured": self.measured,
                "reference": self.reference, "tolerance": self.tolerance, "pass": self.passed}


def phase_order_ok(sy: ParticleSystem, order_bottom_to_top: list[int]) -> bool:
    """Phases in ``order_bottom_to_top`` by mean height (:func:`dcdc.metrics.phase_order_ok`)."""
    return metrics.phase_order_ok(sy.x, sy.phase, order_bottom_to_top)


def layer_purity(sy: ParticleSystem, order_bottom_to_top: list[int], floor: float,
                 area: float, V0: float) -> float:
    """Ideal-layer purity (:func:`dcdc.metrics.ideal_layer_purity`, ± one spacing)."""
    return metrics.ideal_layer_purity(sy.x, sy.phase, order_bottom_to_top, floor, area, V0,
                                      sy.spacing)


def trapped_below(sy: ParticleSystem, light: int, heavy_below: list[int], floor: float,
                  area: float, V0: float) -> float:
    """Fraction of phase ``light`` still more than one spacing below the interface, the top
    of the ideal layers of the phases ``heavy_below`` (heights N_k V0 / area from ``floor``):
    light fluid held under heavy fluid, e.g. by walls that grip (docs/sph.md, "Walls")."""
    top = floor + sum(int((sy.phase == k).sum()) for k in heavy_below) * V0 / area
    m = sy.phase == light
    return float((sy.x[m, 1] < top - sy.spacing).sum() / max(int(m.sum()), 1))


def phase_volumes(sim: Simulator) -> np.ndarray:
    """Volume per phase V_k = Σ m_i/ρ_i with ρ_i = ρ0_i max(ψ_i, 1): compression shrinks it,
    while the kernel deficiency at a free surface (ψ < 1) is not counted as expansion."""
    psi = sim.density() / sim.system.rest_density
    vol = sim.V0 / np.maximum(psi, 1.0)
    return np.bincount(sim.system.phase, weights=vol, minlength=len(sim.system.phases))


class EnergyBudget:
    """Energy check of a closed tank with static walls: the kinetic energy can never exceed
    the potential energy released since the start (pressure and viscosity only exchange or
    dissipate it). Call after each frame; :meth:`excess` is the worst KE - ΔPE over the
    frames, relative to the ΔPE released by the end (< 0: no energy was created)."""

    def __init__(self, sim: Simulator):
        self.mass = sim.system.rest_density * sim.V0
        self.g = -np.asarray(sim.system.gravity, dtype=np.float64)
        self.pe0 = self._pe(sim)
        self.worst = -np.inf
        self.released = 0.0

    def _pe(self, sim: Simulator) -> float:
        return float(self.mass @ (sim.system.x @ self.g))

    def __call__(self, sim: Simulator, frame: int) -> None:
        ke = 0.5 * float(self.mass @ (sim.system.v ** 2).sum(1))
        self.released = self.pe0 - self._pe(sim)
        self.worst = max(self.worst, ke - self.released)

    def excess(self) -> float:
        return self.worst / max(self.released, 1e-30)

    def row(self, case: str) -> "Row":
        e = self.excess()
        return Row(case, "max (KE - released PE) / PE released", e, "<= 0", "< 0.01",
                   bool(e < 0.01))


def run(sim: Simulator, duration: float, every: Callable | None = None) -> dict:
    """Advance ``duration`` in frames; track the largest speed, the largest 99th percentile
    of the speeds (the bulk of the fluid, without the few particles an impact squirts
    along a wall) and substep statistics."""
    n = int(round(duration / FRAME_DT))
    vmax = v99 = 0.0
    subs = 0
    for f in range(n):
        st = sim.advance(FRAME_DT)
        vmax = max(vmax, st["max_speed"])
        v99 = max(v99, float(np.percentile(np.linalg.norm(sim.system.v, axis=1), 99)))
        subs += st["substeps"]
        if every is not None:
            every(sim, f)
    return {"max_speed": vmax, "p99_speed": v99, "substeps": subs}


def surge_front(sy: ParticleSystem) -> float:
    """Leading edge of a surge along +x: the foremost particle + r; in 3-D the median over
    slices 2r wide across the tank of each slice's foremost particle, so one particle
    splashing ahead somewhere across the 0.4 m wide tank does not define the front (Martin
    & Moyce read the front line across their tank)."""
    x = sy.x[:, 0]
    if sy.dim == 2:
        return float(x.max() + sy.radius)
    k = np.floor(sy.x[:, 2] / sy.spacing).astype(np.int64)
    k -= k.min()
    front = np.full(k.max() + 1, -np.inf)
    np.maximum.at(front, k, x)
    return float(np.median(front[np.isfinite(front)]) + sy.radius)


class ClosestPair:
    """The smallest distance between two fluid particles over the frames, in particle radii
    (call after each frame; scipy's k-d tree). Lattice neighbours are 2 r apart; below
    :data:`COINCIDENT` r two particles overlap by most of a spacing, which an incompressible
    fluid cannot hold (``dcdc generate`` refuses such trajectories)."""

    def __init__(self, sim: Simulator):
        self.r = sim.system.radius
        self.closest = math.inf
        self.time = 0.0
        self(sim, -1)

    def __call__(self, sim: Simulator, frame: int) -> None:
        from scipy.spatial import cKDTree

        x = sim.system.x
        d = cKDTree(x).query(x, k=2)[0][:, 1].min() / self.r
        if d < self.closest:
            self.closest, self.time = float(d), sim.time


COINCIDENT = 0.3  # [particle radii] as dcdc.data.generate.COINCIDENT


def exchange_fronts(x: np.ndarray, phase: np.ndarray, H: float, spacing: float,
                    heavy: int = 0, light: int = 1, q: float = 99.0) -> tuple[float, float]:
    """Front positions of a lock exchange (heavy on the left): the ``q``-th percentile of x of
    the heavy particles within 2 spacings of the floor, and the (100 - ``q``)-th percentile of
    x of the light particles within 2 spacings of the lid. Percentiles rather than the
    extreme particle, so that one particle squirted ahead does not set the front."""
    low = (phase == heavy) & (x[:, 1] < 2.0 * spacing)
    high = (phase == light) & (x[:, 1] > H - 2.0 * spacing)
    xh = float(np.percentile(x[low, 0], q)) if low.any() else float("nan")
    xl = float(np.percentile(x[high, 0], 100.0 - q)) if high.any() else float("nan")
    return xh, xl


def front_speed(t, xf) -> float:
    """Least-squares slope dx/dt of front positions ``xf`` at times ``t``."""
    return float(np.polyfit(np.asarray(t, float), np.asarray(xf, float), 1)[0])


def current_rows(r: float, H: float) -> float:
    """Particle rows across one current of the lock exchange: half the depth ``H`` over the
    spacing 2 ``r``."""
    return round(0.5 * H / (2.0 * r), 6)


def standard_error(values) -> float:
    """Standard error of the mean of ``values`` (sample standard deviation / sqrt(n))."""
    v = np.asarray(values, dtype=float)
    return float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")


def extrapolate_to_zero(radii, values, errors, order: int = 1) -> tuple[float, float]:
    """Richardson-style extrapolation of a quantity measured at several resolutions: the
    weighted least-squares fit ``value = a + b r^order`` (weights 1 / error²) and its
    intercept ``a`` = the value at r -> 0, with the intercept's standard error from
    ``errors`` (each value's standard error). ``order`` is the assumed convergence order
    (SPH on disordered particles: 1; on a lattice 2). Without usable errors (one start per
    radius: NaN; or all zero) the points weigh alike and the standard error is NaN."""
    r = np.asarray(radii, dtype=float) ** order
    y, e = np.asarray(values, dtype=float), np.asarray(errors, dtype=float)
    usable = bool(np.all(np.isfinite(e)) and np.all(e > 0))
    w = 1.0 / e ** 2 if usable else np.ones_like(y)
    A = np.stack([np.ones_like(r), r], axis=1)
    cov = np.linalg.inv(A.T @ (w[:, None] * A))
    a, _ = cov @ (A.T @ (w * y))
    return float(a), float(np.sqrt(cov[0, 0])) if usable else float("nan")


def drop_radius(n_drop: int, V0: float, dim: int) -> float:
    """Radius [m] of a disc (sphere) holding ``n_drop`` particles of volume ``V0``."""
    return (n_drop * V0 / math.pi) ** 0.5 if dim == 2 else (3 * n_drop * V0 / (4 * math.pi)) ** (1 / 3)


def max_radius_ratio(x_drop: np.ndarray, r: float, R: float) -> float:
    """The drop's outermost particle edge from its centre of mass, over R (1 when round)."""
    return float(np.linalg.norm(x_drop - x_drop.mean(0), axis=1).max() + r) / R


def cap_contact_angle(x: np.ndarray, phase: np.ndarray, drop: int, r: float) -> float:
    """Contact angle [degrees, through the drop] of a cap-shaped drop of phase ``drop`` on
    the floor y = 0: a least-squares circle (sphere) through the drop's particles that have
    an unlike neighbour within 4.5 r (the "pairwise" tension keeps unlike neighbours about
    two spacings apart) more than 2.5 r above the floor, whose centre height c and radius
    R (+ r, the particles' half spacing) give cos θ = −c / R."""
    unlike = metrics.same_phase_fraction(x, phase, 4.5 * r) < 1.0  # NaN (alone): False
    P = x[(phase == drop) & unlike & (x[:, 1] > 2.5 * r)]
    d = x.shape[1]
    sol = np.linalg.lstsq(np.c_[2.0 * P, np.ones(len(P))], (P ** 2).sum(1), rcond=None)[0]
    centre = sol[:d]
    R = math.sqrt(sol[d] + centre @ centre) + r
    return math.degrees(math.acos(min(1.0, max(-1.0, -centre[1] / R))))
