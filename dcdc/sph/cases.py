"""Validation scenes of ``dcdc validate-sph`` and their measurements.

Every case builds a tank of wall particles (:func:`dcdc.geometry.sample_walls` on
:func:`dcdc.geometry.shapes.container`) holding blocks of fluid on the rest lattice, runs the
solver, and returns rows ``(case, quantity, measured, reference, tolerance, passed)``.
Quick variants are coarser and shorter (they run in the test suite); full variants are what
the README reports.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import metrics
from ..geometry import lattice, sample_walls
from ..geometry.shapes import container
from ..particles import ParticleSystem, Phase
from .config import SPHConfig
from .forces import xsph_viscosity
from .reference import closed_container
from .solver import Simulator

G = 9.81
FRAME = 0.02

# Martin & Moyce (1952), "Part IV. An experimental study of the collapse of liquid columns on
# a rigid horizontal plane", Phil. Trans. R. Soc. Lond. A 244, 312-324, Fig. 3, column of
# width a = 2.25 in and height 2a (n² = 2): surge front Z = z/a against T = t·sqrt(2g/a),
# as digitised in PySPH (pysph/examples/db_exp_data.py). Points up to Z ≈ 4.
MARTIN_MOYCE_T = np.array([0.832, 1.219, 1.997, 2.547, 3.345])
MARTIN_MOYCE_Z = np.array([1.217, 1.474, 2.292, 2.995, 4.134])


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


# ---------------------------------------------------------------------------- scene building
def tank_system(dim: int, r: float, size, blocks, phases: list[Phase], wall_height=None,
                name: str = "tank", closed: bool = False) -> ParticleSystem:
    """Tank with inner box [0, size] (walls ``wall_height`` tall; a lid there if ``closed``,
    which keeps the jets of a 10:1 collapse in the tank) and fluid blocks.

    ``blocks``: list of (lo, hi, phase_of) where ``phase_of(points) -> phase index or -1``
    may split a block between phases (or drop points). Fluid sits on the lattice
    ``r + 2r·k`` so that the first layer is one spacing from the wall particles."""
    s = 2.0 * r
    size = np.asarray(size, dtype=np.float64)[:dim]
    lo = np.zeros(dim)
    top = np.array(size)
    top[1] = size[1] if wall_height is None else wall_height
    xs, ph = [], []
    for blo, bhi, phase_of in blocks:
        pts = lattice(np.asarray(blo, float)[:dim] + r, np.asarray(bhi, float)[:dim] - r, s,
                      anchor=lo + r)
        idx = np.asarray(phase_of(pts), dtype=np.int64)
        keep = idx >= 0
        xs.append(pts[keep])
        ph.append(idx[keep])
    x = np.concatenate(xs)
    phase = np.concatenate(ph)
    sdf = container(lo - r, top + r, open_top=not closed)
    pad = 2 * s + 0.5 * r
    whi = top + r + pad
    if not closed:
        whi[1] = top[1] + r
    wx, wn = sample_walls(sdf, lo - r - pad, whi, s, 2 * s, anchor=lo - r)
    dom_lo = lo - 2 * s - 0.05
    dom_hi = top + 2 * s + 0.05
    dom_hi[1] = top[1] + 2.0
    gravity = np.array([0.0, -G, 0.0])[:dim]
    # the tank's inner box (the wall face lies half a spacing outside the first fluid layer),
    # for exporters such as dcdc.sph.splishsplash
    meta = {"container": (lo.tolist(), top.tolist())}
    # the solid for the walls' volume map: its surface is the tank's inner box, where the
    # fluid's lattice cells end (the wall particles' sampling surface lies r further out)
    solid = container(lo, top, open_top=not closed)
    return ParticleSystem(dim, r, x, np.zeros_like(x), phase, phases, wx, wn, gravity,
                          (dom_lo, dom_hi), name=name, meta=meta, wall_sdf=solid)


def _radius(dim: int, quick: bool) -> float:
    """Particle radius of the multiphase cases: quick 2.5 cm, full 1.25 cm (4-6 k particles
    in the 0.2 m deep 3-D tanks). At 2 cm the 3-D tanks were 5 particles deep, and in the
    10:1 collapse single light particles squeezed out between the heavy front and the wall
    reached 9.7 m/s; at 1.25 cm the fastest particle stayed at 3.0 m/s (measured)."""
    return 0.025 if quick else 0.0125


def _const(i):
    return lambda pts: np.full(len(pts), i)


def _depth_size(dim, w, h, depth):
    return [w, h, depth][:dim]


# ---------------------------------------------------------------------------- measurements
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
    n = int(round(duration / FRAME))
    vmax = v99 = 0.0
    subs = 0
    for f in range(n):
        st = sim.advance(FRAME)
        vmax = max(vmax, st["max_speed"])
        v99 = max(v99, float(np.percentile(np.linalg.norm(sim.system.v, axis=1), 99)))
        subs += st["substeps"]
        if every is not None:
            every(sim, f)
    return {"max_speed": vmax, "p99_speed": v99, "substeps": subs}


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


# lock exchange: tank, densities and the fit window in units of T0 = sqrt(H/g')
LOCK_L, LOCK_H = 1.6, 0.2
LOCK_RHO = (1500.0, 1000.0)
LOCK_WINDOW = (2.0, 5.0)


def lock_exchange_run(r: float, cfg: SPHConfig, L: float = LOCK_L, H: float = LOCK_H,
                      rho=LOCK_RHO, window=LOCK_WINDOW, seed: int = 0) -> dict:
    """One full-depth lock exchange in 2-D: heavy (rho[0]) fills the left half of a closed
    L × H tank, light (rho[1]) the right half, released from rest. Returns the front speeds of
    the heavy current along the floor and of the light current along the lid [m/s] fitted
    over t = window · T0 (T0 = sqrt(H/g'), g' = g Δρ/ρ̄), the fronts' largest distance from
    the middle over the window, N and the wall time. ``seed`` > 0 starts from a random
    velocity of 1 mm/s rms per component instead of rest (an ensemble member).

    The depth is rounded to whole rows of the lattice (0.2 m at r = 10, 5, 2.5 mm; 0.196 m at
    7 and 3.5 mm), so that the fluid fills the closed tank: with 28.6 rows the lattice left a
    4 mm gap under the lid and the light current along it ran 30 % slower (docs/sph.md)."""
    import time
    t0 = time.perf_counter()
    H = 2.0 * r * max(1, round(H / (2.0 * r)))
    phases = [Phase("heavy", rho[0]), Phase("light", rho[1])]
    split = lambda pts: np.where(pts[:, 0] < L / 2, 0, 1)  # noqa: E731
    sy = tank_system(2, r, [L, H], [(np.zeros(3), [L, H, 0.0], split)], phases,
                     wall_height=H, name="lock_exchange", closed=True)
    jitter(sy, seed)
    sim = Simulator(sy, cfg)
    gp = G * (rho[0] - rho[1]) / (0.5 * (rho[0] + rho[1]))
    T0 = math.sqrt(H / gp)
    ts, xh, xl = [], [], []

    def sample(s, f):
        tt = s.time / T0
        if window[0] - 1e-9 <= tt <= window[1] + 1e-9:
            a, b = exchange_fronts(s.system.x, s.system.phase, H, s.system.spacing)
            ts.append(s.time)
            xh.append(a)
            xl.append(b)
    run(sim, window[1] * T0 + FRAME, sample)
    heavy, light = front_speed(ts, xh), -front_speed(ts, xl)
    scale = math.sqrt(gp * H)
    return {"heavy": heavy, "light": light, "fr_heavy": heavy / scale, "fr_light": light / scale,
            "gp": gp, "T0": T0, "H": H, "reach": max(max(xh) - L / 2, L / 2 - min(xl)),
            "n": sy.n_fluid, "wall": time.perf_counter() - t0}


# the per-radius Froude rows are judged where each current (half the depth) is at least this
# many particle rows deep (h/H <= 0.1 with the support h = 2 spacings); coarser radii are
# reported as information: the fronts' shortfall from their speed extrapolated to r -> 0 is
# 17-20 % at 7 rows and 13-14 % at 10 (docs/sph.md, "Closed containers", "The resolution a
# current needs")
LOCK_RESOLVED_ROWS = 10


def current_rows(r: float, H: float) -> float:
    """Particle rows across one current of the lock exchange: half the depth ``H`` over the
    spacing 2 ``r``."""
    return round(0.5 * H / (2.0 * r), 6)


ENSEMBLE_SEEDS = (0, 1, 2)  # the start at rest and two 1 mm/s random starts (:func:`jitter`)
# the lock exchange's damping check compares two ensemble means: one run's heavy front
# changes by 12 % (sd) between equal settings at 10 mm, so three starts leave ±7 % of noise
# on a 5 % tolerance; ten leave ±3.7 % (docs/sph.md, "Closed containers")
DAMPING_SEEDS = tuple(range(10))


def jitter(sy: ParticleSystem, seed: int) -> None:
    """An ensemble member's start: ``seed`` > 0 adds a random velocity of 1 mm/s rms per
    component (seed 0: the start at rest, unchanged)."""
    if seed:
        sy.v += 1e-3 * np.random.default_rng(seed).standard_normal(sy.v.shape)


def _standard_error(values) -> float:
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


def lock_exchange_ensemble(r: float, cfg: SPHConfig, seeds=ENSEMBLE_SEEDS) -> dict:
    """:func:`lock_exchange_run` for each start in ``seeds``: the mean of every front speed
    and Froude number, the spread (max - min) of the heavy and light Froude numbers, the
    largest front travel and the summed wall time. The exchange is chaotic: single runs of
    numerically equal settings differ by 2-5 % (docs/sph.md, "Closed containers")."""
    runs = [lock_exchange_run(r, cfg, seed=k) for k in seeds]
    out = {k: float(np.mean([d[k] for d in runs]))
           for k in ("heavy", "light", "fr_heavy", "fr_light", "gp", "H")}
    out.update(spread_heavy=float(np.ptp([d["fr_heavy"] for d in runs])),
               spread_light=float(np.ptp([d["fr_light"] for d in runs])),
               se_heavy=_standard_error([d["fr_heavy"] for d in runs]),
               se_light=_standard_error([d["fr_light"] for d in runs]),
               reach=max(d["reach"] for d in runs), n=runs[0]["n"],
               wall=sum(d["wall"] for d in runs), runs=len(runs))
    return out


# ---------------------------------------------------------------------------- cases
def hydrostatic(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """Tank at rest: pressure gradient against ρ g, ψ error, residual speed after settling
    (mean over the start at rest and two 1 mm/s random starts, :func:`jitter`: the packing of
    the lattice start settles in sudden rearrangements, so one start is luck either way;
    docs/sph.md, "What holds the thin film").

    r = 1.25 cm (2-D full: 6.25 mm), 40 particles deep. At r = 2.5 cm only 4 rows lie
    outside the kernel support of floor and surface, and the fitted slope of a 3-D tank
    scattered between 0.93 and 1.05 ρ0 g with the tank's depth (measured)."""
    r = 0.00625 if (dim == 2 and not quick) else 0.0125
    W, H = 0.5, 0.5
    size = _depth_size(dim, W, H, 0.15 if quick else 0.2)

    def tank(seed: int = 0) -> ParticleSystem:
        sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), _const(0))],
                         [Phase("water", 1000.0)], wall_height=H + 0.2, name="hydrostatic")
        jitter(sy, seed)
        return sy
    sy = tank()
    sim = Simulator(sy, cfg)
    T = 2.0 if quick else 3.0
    rho0 = 1000.0
    h = sim.h
    area = float(np.prod(np.delete(size, 1)))
    height = sy.n_fluid * sim.V0 / area  # free-surface height of the fluid at rest density
    samples = []  # (y, frame-mean p) of interior particles over the last second
    n_avg = int(1.0 / FRAME)

    def sample(s, f):
        if f >= int(round(T / FRAME)) - n_avg:
            y = s.system.x[:, 1]
            inner = np.ones(s.system.n_fluid, bool)
            for k in range(dim):
                if k != 1:
                    inner &= (s.system.x[:, k] > h) & (s.system.x[:, k] < size[k] - h)
            inner &= (y > 2 * h) & (y < height - h)  # outside the walls' kernel support
            samples.append((y[inner], s.pressure()[inner]))
    run(sim, T, sample)
    ys = np.concatenate([a for a, _ in samples])
    ps = np.concatenate([b for _, b in samples])
    A = np.stack([ys, np.ones(len(ys))], 1)
    slope, icpt = np.linalg.lstsq(A, ps, rcond=None)[0]
    grad_err = abs(-slope / (rho0 * G) - 1.0)
    y = sy.x[:, 1]
    surface = float(np.percentile(y, 99.5)) + r  # measured free surface at the end
    p_mid = slope * (surface / 2) + icpt
    mid_err = abs(p_mid / (rho0 * G * surface / 2) - 1.0)
    psi = sim.density() / rho0
    inner = (y > h) & (y < surface - h)
    dens_err = float(np.abs(psi[inner] - 1.0).mean())
    uref = math.sqrt(G * height)
    others = [tank(seed) for seed in ENSEMBLE_SEEDS[1:]]  # the residual motion is chaotic
    for other in others:
        Simulator(other, cfg).run(T, FRAME)
    speeds = [float(np.linalg.norm(t.v, axis=1).mean()) / uref for t in [sy] + others]
    speed = float(np.mean(speeds))
    c = f"hydrostatic {dim}D (N={sy.n_fluid})"
    return [
        Row(c, "dp/dy / (ρ0 g)", -slope / (rho0 * G), "1", "±5 %", grad_err <= 0.05),
        Row(c, "p(H/2) / (ρ0 g H/2), H = surface", p_mid / (rho0 * G * surface / 2), "1", "±5 %",
            mid_err <= 0.05),
        Row(c, "mean |ρ/ρ0 - 1|", dens_err, "0", "< 1 %", dens_err < 0.01),
        Row(c, f"mean speed / sqrt(gH), mean of {len(speeds)} starts", speed, "0", "< 1 %",
            speed < 0.01),
        Row(c, "mean speed / sqrt(gH), largest start", max(speeds), "0", "info", None),
    ]


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


def dam_break(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """Column a × 2a collapsing on a dry floor: surge front against Martin & Moyce (1952).

    The check is the front's speed dZ/dT between T = 1.22 and 3.35; the positions are
    information. The experiment released its column by removing a barrier, which takes
    a finite time and delays the early front; a simulation released instantaneously leads
    it at first (ours with free-slip walls by 12-16 % at T <= 1.22, as inviscid simulations
    of this experiment do), while the surge's speed once it runs is not affected."""
    a = 0.4 if dim == 3 else 0.5
    # 3-D: one resolution (at r = 0.025 the thin late surge is two particles deep)
    r = (0.025 if quick else 0.0125) if dim == 2 else 0.02
    depth = 0.4 if dim == 3 else 1.0
    L = 5.0 * a
    size = _depth_size(dim, L, 2 * a, depth)
    col = _depth_size(dim, a, 2 * a, depth) + [0] * (3 - dim)
    sy = tank_system(dim, r, size, [(np.zeros(3), col, _const(0))], [Phase("water", 1000.0)],
                     wall_height=2 * a + 0.2, name="dam_break")
    sim = Simulator(sy, cfg)
    tscale = math.sqrt(a / (2 * G))  # t = T · sqrt(a / 2g)
    T_end = MARTIN_MOYCE_T.max() * tscale
    times, fronts = [0.0], [a]

    def track(s, f):
        times.append(s.time)
        fronts.append(surge_front(s.system))
    run(sim, math.ceil(T_end / FRAME) * FRAME + FRAME, track)
    Z = np.interp(MARTIN_MOYCE_T * tscale, times, fronts) / a
    c = f"dam break {dim}D (N={sy.n_fluid})"
    rows = [Row(c, f"front Z at T={T:.2f}", float(z), f"{zr:.3f}", f"{100 * (z / zr - 1):+.0f} %",
                None) for T, z, zr in zip(MARTIN_MOYCE_T, Z, MARTIN_MOYCE_Z)]
    dT = MARTIN_MOYCE_T[-1] - MARTIN_MOYCE_T[1]
    speed = float((Z[-1] - Z[1]) / dT)
    ref = float((MARTIN_MOYCE_Z[-1] - MARTIN_MOYCE_Z[1]) / dT)
    rows.append(Row(c, "front speed dZ/dT, T = 1.22-3.35", speed, f"{ref:.3f}", "±10 %",
                    bool(abs(speed / ref - 1.0) <= 0.10)))
    return rows


def _closed_tank(dim: int, quick: bool, W: float, H: float, phases: list[Phase], assign,
                 name: str):
    """A closed tank of inner size W × H (× 0.2 deep in 3-D, walls 2H + 0.2 tall) filled with
    one block whose particles ``assign`` maps to phase indices; its Simulator and floor area."""
    size = _depth_size(dim, W, H, 0.2)
    sy = tank_system(dim, _radius(dim, quick), size,
                     [(np.zeros(3), size + [0] * (3 - dim), assign)], phases,
                     wall_height=2 * H + 0.2, name=name, closed=True)
    return sy, float(np.prod(np.delete(size, 1)))


def _layer_rows(c: str, sy: ParticleSystem, sim: Simulator, area: float, order: list[int],
                order_label: str, purity_min: float) -> list[Row]:
    """Rows: phases in ``order`` (bottom to top) by mean height, and layer purity."""
    ok = phase_order_ok(sy, order)
    purity = layer_purity(sy, order, 0.0, area, sim.V0)
    return [Row(c, order_label, float(ok), "1", "= 1", ok),
            Row(c, "layer purity", purity, "1", f">= {purity_min:g}", purity >= purity_min)]


def side_by_side(dim: int, quick: bool, cfg: SPHConfig, ratio: float = 10.0) -> list[Row]:
    """Heavy and light phase (ratio:1) side by side settle into layers, heavy below."""
    W, H = 0.8, 0.4
    phases = [Phase("heavy", 1000.0), Phase("light", 1000.0 / ratio)]
    split = lambda pts: np.where(pts[:, 0] < W / 2, 0, 1)  # noqa: E731
    sy, area = _closed_tank(dim, quick, W, H, phases, split, "side_by_side")
    sim = Simulator(sy, cfg)
    v_start = phase_volumes(sim)
    T = 3.0 if quick else 5.0
    energy = EnergyBudget(sim)
    stats = run(sim, T, energy)
    v_end = phase_volumes(sim)
    dvol = np.abs(v_end / v_start - 1.0)
    vbound = 2.0 * math.sqrt(2 * G * H)
    c = f"{ratio:g}:1 side by side {dim}D (N={sy.n_fluid})"
    trapped = trapped_below(sy, 1, [0], 0.0, area, sim.V0)
    return _layer_rows(c, sy, sim, area, [0, 1], "heavy below light", 0.9) + [
        Row(c, "light left below the interface", trapped, "0", "< 0.2 %", trapped < 0.002),
        Row(c, "volume change heavy", float(dvol[0]), "0", "< 2 %", bool(dvol[0] < 0.02)),
        Row(c, "volume change light", float(dvol[1]), "0", "< 2 %", bool(dvol[1] < 0.02)),
        # the bulk's speed is bounded by free fall from the full height (x2 margin); single
        # particles squirted by an impact are not (the energy row bounds them all together)
        Row(c, "99th percentile speed [m/s]", stats["p99_speed"], f"< {vbound:.2f}",
            "finite, bounded", bool(np.isfinite(stats["p99_speed"]) and stats["p99_speed"] < vbound)),
        Row(c, "max speed [m/s]", stats["max_speed"], "finite", "info", None),
        energy.row(c),
    ]


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
HIGH_RATIOS = (15.0, 20.0)


def high_ratio_run(dim: int, r: float, ratio: float, cfg: SPHConfig, T: float) -> dict:
    """Heavy (1000·``ratio``) and light (1000 kg/m³) side by side in a completely filled,
    closed 0.8 × 0.4 m tank (× 0.2 m in 3-D; the depth rounded to whole rows), released
    from rest for ``T`` s: the closest approach of two particles over all frames
    (:class:`ClosestPair`), both phases' mean heights, layer purity and volume change."""
    W = 0.8
    H = 2.0 * r * max(1, round(0.4 / (2.0 * r)))
    phases = [Phase("heavy", 1000.0 * ratio), Phase("light", 1000.0)]
    split = lambda pts: np.where(pts[:, 0] < W / 2, 0, 1)  # noqa: E731
    size = _depth_size(dim, W, H, 0.2)
    sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), split)], phases,
                     wall_height=H, name="high_ratio", closed=True)
    sim = Simulator(sy, cfg)
    area = float(np.prod(np.delete(size, 1)))
    v_start = phase_volumes(sim)
    closest = ClosestPair(sim)
    stats = run(sim, T, closest)
    dvol = np.abs(phase_volumes(sim) / v_start - 1.0)
    return {"n": sy.n_fluid, "H": H, "closest": closest.closest, "closest_t": closest.time,
            "order": phase_order_ok(sy, [0, 1]),
            "purity": layer_purity(sy, [0, 1], 0.0, area, sim.V0),
            "heights": [float(sy.x[sy.phase == k, 1].mean()) for k in (0, 1)],
            "dvol": dvol.tolist(), "max_speed": stats["max_speed"]}


def high_ratio(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """15:1 and 20:1 (:data:`HIGH_RATIOS`): heavy and light side by side in a completely
    filled closed tank (no free surface, so no spray) settle into layers, heavy below, with
    no two particles closer than :data:`COINCIDENT` r in any frame and each phase's volume
    within 2 %. The ideal layers are H/2 deep each: mean heights H/4 and 3H/4. Quick:
    r = 25 mm (2-D N = 128, 3-D N = 512, four rows deep), 3 s; full: 2-D 6.25 mm, 3-D
    12.5 mm, 5 s. The 3-D quick rows' closest pair fails at present (0.03-0.13 r): particles
    meet where the pressure is zero (docs/sph.md, "High density ratios")."""
    if quick:
        r, T = 0.025, 3.0
    else:
        r, T = (0.00625 if dim == 2 else 0.0125), 5.0
    rows = []
    for ratio in HIGH_RATIOS:
        d = high_ratio_run(dim, r, ratio, cfg, T)
        c = f"{ratio:g}:1 filled tank {dim}D (N={d['n']})"
        ideal = f"{d['H'] / 4:.3f} / {3 * d['H'] / 4:.3f}"
        rows += [
            Row(c, "heavy below light", float(d["order"]), "1", "= 1", bool(d["order"])),
            Row(c, "layer purity", d["purity"], "1", ">= 0.9", bool(d["purity"] >= 0.9)),
            Row(c, "mean heights heavy / light [m]", d["heights"][0],
                f"{ideal}", f"light {d['heights'][1]:.3f}; info", None),
            Row(c, f"closest pair over all frames [r] (at {d['closest_t']:.2f} s)",
                d["closest"], ">= 0.3", f">= {COINCIDENT:g}", bool(d["closest"] >= COINCIDENT)),
            Row(c, "volume change heavy", d["dvol"][0], "0", "< 2 %", bool(d["dvol"][0] < 0.02)),
            Row(c, "volume change light", d["dvol"][1], "0", "< 2 %", bool(d["dvol"][1] < 0.02)),
            Row(c, "max speed [m/s]", d["max_speed"], "finite", "info", None),
        ]
    return rows


def rayleigh_taylor(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """Heavy (2000) above light (1000) with a cosine-perturbed interface inverts."""
    W, H = 0.6, 0.8
    amp = 0.05
    heavy_above = lambda pts: np.where(  # noqa: E731
        pts[:, 1] > H / 2 + amp * np.cos(2 * np.pi * pts[:, 0] / W), 0, 1)
    phases = [Phase("heavy", 2000.0), Phase("light", 1000.0)]
    sy, area = _closed_tank(dim, quick, W, H, phases, heavy_above, "rayleigh_taylor")
    sim = Simulator(sy, cfg)
    energy = EnergyBudget(sim)
    stats = run(sim, 4.0 if quick else 8.0, energy)
    c = f"Rayleigh-Taylor 2:1 {dim}D (N={sy.n_fluid})"
    return _layer_rows(c, sy, sim, area, [0, 1], "inverted (heavy below)", 0.8) + [
        Row(c, "max speed [m/s]", stats["max_speed"], "finite", "finite",
            bool(np.isfinite(stats["max_speed"]))),
        energy.row(c),
    ]


def four_phase(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """Layers 3000/1500/1000/700 stacked in reverse (lightest at the bottom) sort themselves.

    Full: 25 s. The sorting is slow near the side walls, where a light particle feels about
    half its buoyancy (docs/sph.md, "Known limits"); in 2-D the layer purity was 0.58-0.61
    after 15 s and 0.65-0.68 after 25 s over runs with perturbed substeps (measured)."""
    W, H = 0.4, 1.0
    dens = [700.0, 1000.0, 1500.0, 3000.0]
    phases = [Phase(f"rho{int(d)}", d) for d in dens]
    layer = lambda pts: np.clip((pts[:, 1] / (H / 4)).astype(int), 0, 3)  # noqa: E731
    # phase 0 (700) at the bottom ... phase 3 (3000) on top: the reverse of equilibrium
    sy, area = _closed_tank(dim, quick, W, H, phases, layer, "four_phase")
    sim = Simulator(sy, cfg)
    energy = EnergyBudget(sim)
    stats = run(sim, 10.0 if quick else 25.0, energy)
    order = [3, 2, 1, 0]
    ys = [float(sy.x[sy.phase == k, 1].mean()) for k in order]
    c = f"four phases {dim}D (N={sy.n_fluid})"
    return _layer_rows(c, sy, sim, area, order, "order 3000<1500<1000<700 (mean y)", 0.6) + [
        Row(c, "mean heights [m] (3000/1500/1000/700)", ys[0], " / ".join(f"{v:.2f}" for v in ys),
            "info", None),
        Row(c, "max speed [m/s]", stats["max_speed"], "finite", "finite",
            bool(np.isfinite(stats["max_speed"]))),
        energy.row(c),
    ]


def laplace_box(dim: int) -> float:
    """Side [m] of the `laplace` case's closed box: 0.4 in 2-D, 0.3 in 3-D."""
    return 0.4 if dim == 2 else 0.3


def _laplace_half(dim: int) -> float:
    """Half side [m] of the `laplace` case's square (cube) drop: the area of a disc of radius
    0.1 m (the volume of a sphere of 0.09 m)."""
    return 0.5 * (math.sqrt(math.pi) * 0.1 if dim == 2 else (4.0 * math.pi / 3.0) ** (1 / 3) * 0.09)


def laplace_drop(dim: int, r: float, densities: tuple = (1000.0, 1000.0)) -> ParticleSystem:
    """The `laplace` case's start: a square (cube) drop of phase "drop" (a disc of radius
    0.1 m / a sphere of 0.09 m by volume) in the middle of a closed box (:func:`laplace_box`)
    filled with phase "ambient", densities (ambient, drop) [kg/m³], gravity off."""
    W = laplace_box(dim)
    half = _laplace_half(dim)
    c = W / 2
    inside = lambda p: np.where((np.abs(p - c) < half).all(1), 1, 0)  # noqa: E731
    phases = [Phase("ambient", float(densities[0])), Phase("drop", float(densities[1]))]
    size = [W] * dim
    sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), inside)], phases,
                     wall_height=W, name="laplace", closed=True)
    sy.gravity[:] = 0.0
    return sy


def drop_radius(n_drop: int, V0: float, dim: int) -> float:
    """Radius [m] of a disc (sphere) holding ``n_drop`` particles of volume ``V0``."""
    return (n_drop * V0 / math.pi) ** 0.5 if dim == 2 else (3 * n_drop * V0 / (4 * math.pi)) ** (1 / 3)


def max_radius_ratio(x_drop: np.ndarray, r: float, R: float) -> float:
    """The drop's outermost particle edge from its centre of mass, over R (1 when round)."""
    return float(np.linalg.norm(x_drop - x_drop.mean(0), axis=1).max() + r) / R


def laplace_run(dim: int, r: float, cfg: SPHConfig, sigma: float = 10.0,
                densities: tuple = (1000.0, 1000.0), duration: float = 2.5) -> dict:
    """Run the `laplace` drop (:func:`laplace_drop`) with σ [N/m] between drop and ambient
    under the settings ``cfg`` and return its Young-Laplace ratio ``jump`` =
    Δp / (σ/R) (2-D) or Δp / (2σ/R) (3-D), Δp = p(drop, dist < R/2) − p(ambient beyond
    R + h, h/2 from the walls) averaged over the last 0.5 s, with R from the drop's
    volume; ``shape`` = :func:`max_radius_ratio` at the end, ``start`` that of the square
    (cube), and N, R."""
    W = laplace_box(dim)
    sy = laplace_drop(dim, r, densities)
    cfg = SPHConfig.from_dict({**cfg.to_dict(), "interfacial_tension": {"ambient/drop": sigma}})
    sim = Simulator(sy, cfg)
    drop = sy.phase == 1
    R = drop_radius(int(drop.sum()), sim.V0, dim)
    p_in, p_out = [], []

    def sample(s, f):
        if s.time > duration - 0.5 - 1e-9:
            centre = s.system.x[drop].mean(0)
            dist = np.linalg.norm(s.system.x - centre, axis=1)
            # ambient beyond the band and half a support from the walls (a full support left
            # no particle in the 3-D quick box)
            walls = np.min(np.minimum(s.system.x, W - s.system.x), 1)
            far = (~drop) & (dist > R + sim.h) & (walls > 0.5 * sim.h)
            p = s.pressure()
            p_in.append(float(p[drop & (dist < 0.5 * R)].mean()))
            p_out.append(float(p[far].mean()))
    run(sim, duration, sample)
    dp = float(np.mean(p_in) - np.mean(p_out))
    start = (math.sqrt(2) if dim == 2 else math.sqrt(3)) * _laplace_half(dim) / R
    return {"jump": dp / ((1 if dim == 2 else 2) * sigma / R),
            "shape": max_radius_ratio(sy.x[drop], r, R),
            "start": start, "N": sy.n_fluid, "R": R}


def laplace(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """A square (cube) droplet in a closed box of a second phase, no gravity: it relaxes to
    round and its pressure jump matches Young-Laplace, Δp = σ/R in 2-D and 2σ/R in 3-D
    (R from the droplet's volume), with the interfacial tension of dcdc.sph.interfaces.
    σ = 10 N/m (per unit depth in 2-D) makes Δp ~ 100 Pa, well above the frame pressure's
    noise at these resolutions; the densities are equal (1000); 2.5 s (the 3-D quick drop,
    under 4 spacings in radius, builds its jump over 2 s)."""
    r = (0.01 if quick else 0.005) if dim == 2 else (0.0125 if quick else 0.01)
    m = laplace_run(dim, r, cfg)
    label = f"Laplace droplet {dim}D (N={m['N']}, R={m['R'] * 100:.1f} cm)"
    return [
        Row(label, "Δp / (σ/R)" if dim == 2 else "Δp / (2σ/R)", m["jump"], "1", "±15 %",
            bool(abs(m["jump"] - 1) <= 0.15)),
        Row(label, f"max radius / R (square start {m['start']:.2f})", m["shape"], "1", "< 1.1",
            bool(m["shape"] < 1.1)),
    ]


def floor_drops_run(dim: int, sigma: float, T: float = 3.0, r: float = 0.025) -> dict:
    """Particle-size drops on a wall: single light particles (700 kg/m³, every sixth of the
    floor row; 3-D also every fourth across) under a 0.4 m column of 2000 kg/m³ (0.6 m wide,
    3-D 0.2 m deep) with the "pairwise" tension σ between them (none for σ = 0), run ``T`` s.
    Returns the share that rose more than two spacings, the median rise [r], the number of
    drops and their Bond number Δρ g (2r)² / σ (docs/sph.md, "Walls for the pairwise
    tension": Fritz's departure at Bo ≈ 3.5 for 90°)."""
    depth = 0.4
    size = [0.6, depth + 0.1] + ([0.2] if dim == 3 else [])

    def fill(p):
        pick = (p[:, 1] < 2 * r) & (np.abs((p[:, 0] / (2 * r)) % 6 - 3) < 0.6)
        if dim == 3:
            pick &= np.abs((p[:, 2] / (2 * r)) % 4 - 2) < 0.6
        return np.where(pick, 1, np.where(p[:, 1] > depth, -1, 0))
    sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), fill)],
                     [Phase("heavy", 2000.0), Phase("light", 700.0)], name="drops")
    light = sy.phase == 1
    y0 = sy.x[light, 1].copy()
    cfg = {"interfacial_tension": {"heavy/light": sigma}, "interfacial_model": "pairwise"}
    Simulator(sy, SPHConfig.from_dict(cfg if sigma > 0 else {})).run(T, FRAME)
    rise = sy.x[light, 1] - y0
    return {"risen": float(np.mean(rise > 4 * r)), "median_rise_r": float(np.median(rise)) / r,
            "drops": int(light.sum()),
            "bond": 1300.0 * G * (2 * r) ** 2 / sigma if sigma > 0 else math.inf}


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


def sessile_drop_run(dim: int, theta: float, r: float = 0.005, R: float = 0.08,
                     sigma: float = 1.0, duration: float = 3.0, settings: dict | None = None,
                     every: float = 0.25, start: float = 90.0) -> dict:
    """A cap of a disc (sphere) of phase "drop" of radius ``R`` on the floor of a closed
    0.5 × 0.25 (× 0.5) m box of phase "ambient", equal densities, no gravity, "pairwise"
    tension σ and the walls' tensions that make Young's angle ``theta`` [degrees, through
    the drop]: cos θ = (σ_w,ambient − σ_w,drop) / σ (:func:`dcdc.sph.interfaces.coefficients`).
    The cap starts at the angle ``start`` (90°: a half disc / hemisphere; its centre at
    −R cos(start) above the floor) and relaxes towards θ; returns the angle
    (:func:`cap_contact_angle`) every ``every`` s, N and the wall time."""
    import time
    W, H = 0.5, 0.25
    size = [W, H] + ([W] if dim == 3 else [])
    foot = np.array([W / 2, -R * math.cos(math.radians(start)), W / 2])[:dim]
    inside = lambda p: np.where(np.linalg.norm(p - foot, axis=1) < R, 1, 0)  # noqa: E731
    sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), inside)],
                     [Phase("ambient", 1000.0), Phase("drop", 1000.0)], wall_height=H,
                     name="sessile_drop", closed=True)
    sy.gravity[:] = 0.0
    c = sigma * math.cos(math.radians(theta))
    walls = {"ambient": c} if c > 0 else {"drop": -c}
    cfg = SPHConfig.from_dict({**(settings or {}), "interfacial_model": "pairwise",
                               "interfacial_tension": {"ambient/drop": sigma},
                               "wall_tension": walls})
    sim = Simulator(sy, cfg)
    t0 = time.perf_counter()
    angles = []
    for _ in range(int(round(duration / every))):
        sim.run(every, FRAME)
        angles.append(cap_contact_angle(sy.x, sy.phase, 1, r))
    return {"theta": angles, "n": sy.n_fluid, "wall": time.perf_counter() - t0}


def _damping_reynolds(cfg: SPHConfig, r: float, run: dict) -> float:
    """The lock exchange's Reynolds number UH/ν with ν the stabilisation's: XSPH as a
    viscosity (:func:`dcdc.sph.forces.xsph_viscosity`, at the speed-floor CFL substep) plus
    the artificial viscosity; U = ½ sqrt(g'H)."""
    dt = min(cfg.dt_max, cfg.cfl * 2.0 * r / cfg.speed_floor)
    nu = xsph_viscosity(cfg.xsph, r, cfg.support, dt, 2) + cfg.viscosity
    U = 0.5 * math.sqrt(run["gp"] * run["H"])
    return U * run["H"] / nu if nu > 0 else math.inf


def _halved_damping(settings: dict) -> SPHConfig:
    """These solver settings with ``xsph`` and ``viscosity`` halved."""
    return SPHConfig.from_dict({**settings, "xsph": 0.5 * settings["xsph"],
                                "viscosity": 0.5 * settings["viscosity"]})


def lock_exchange(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """Full-depth lock exchange (2-D): 1500 | 1000 kg/m³ side by side in a closed 1.6 × 0.2 m
    tank (free-slip floor and lid) exchange as two gravity currents, the heavy one along the
    floor, the light one along the lid. After the release each front runs at a constant speed
    until it nears an end wall; the energy-conserving (Benjamin 1968, J. Fluid Mech. 31,
    209-248) speed in the Boussinesq limit is

        U = ½ sqrt(g' H),  Fr = U / sqrt(g' H) = ½,   g' = g (ρ1 - ρ2) / ρ̄,  ρ̄ = (ρ1 + ρ2)/2,

    each current filling half the depth; lock-exchange experiments give Fr ≈ 0.44-0.5
    (Shin, Dalziel & Linden 2004, J. Fluid Mech. 521, 1-34, "Gravity currents produced by
    lock exchange"). Away from the Boussinesq limit the energy-conserving flow-force balance
    with Bernoulli along floor and lid gives U_heavy² = g H Δρ / (4 ρ2) and
    U_light² = g H Δρ / (4 ρ1) (derived here; Lowe, Rottman & Linden 2005, J. Fluid Mech.
    537, found the light front energy-conserving and the heavy one dissipative): at 1.5:1,
    Fr = 0.559 (heavy) and 0.456 (light) with the mean-density g' above, both inside the
    ±15 % band about ½ that the rows use (the band covers experiments and this correction).

    Fronts (:func:`exchange_fronts`) are fitted over t = 2-5 T0, T0 = sqrt(H/g') = 0.23 s:
    after the release's acceleration, and (at U = ½ sqrt(g'H) = 0.44 m/s) at most 0.5 m from
    the middle, 0.3 m = 1.5 H short of the end walls (the row "front travel" reports it).

    The checks run the settings of the closed scenes we ship (the built-in ``lock_exchange``
    and ``hourglass``): the given settings with the hydrostatic reference of the light
    phase, the level at the lid, and a tenth of the default damping
    (:func:`dcdc.sph.reference.closed_container`; docs/sph.md, "Closed containers").
    Rows: Fr of both fronts at each radius, judged where the current is resolved
    (:data:`LOCK_RESOLVED_ROWS` = 10 particle rows per current, r <= 5 mm) and information
    below (10 mm: 5 rows, 7 mm: 7; the rows say so); the heavy front's speed change with the XSPH
    filter and the artificial viscosity halved (< 5 %: the exchange is inviscid, so
    numerical dissipation should not set its speed); and convergence, the heavy speed's
    change between the two finest radii smaller than between the two coarsest, or < 5 %;
    and the converged speed: each front's Fr extrapolated to r -> 0 from the three radii
    (:func:`extrapolate_to_zero`, first order, weighted by the ensembles' standard errors)
    within the band, the second-order extrapolation as information (how much the converged
    value depends on the order assumed). The coarse radii's own rows are kept as information:
    at 7 mm (h/H = 0.14) the fronts are 17-20 % slower than the extrapolated speed, the
    discretisation error of that resolution.
    Information rows give the Reynolds number UH/ν of the stabilisation at each radius
    (:func:`_damping_reynolds`), both fronts with XSPH and artificial viscosity switched off,
    and both fronts with the given settings as they are (the defaults of open scenes: no
    reference, the full damping) and their change when that damping is halved.
    Every closed-settings number is the mean of an ensemble of starts
    (:func:`lock_exchange_ensemble`): three, ten (:data:`DAMPING_SEEDS`) where the damping is
    halved and for the same radius without. Quick: r = 10 mm with and without the halving
    (the fronts there information) and the fronts at 5 mm (three starts); full: r = 7 / 5 /
    3.5 mm, the halving and the information rows at 5 mm. 2-D only: in 3-D
    the case returns an information row (a 3-D tank a few particles deep would add side walls,
    whose grip on buoyancy is a known limit, docs/sph.md)."""
    if dim != 2:
        return [Row("lock exchange 3D", "not run (2-D only)", float("nan"), "-", "info", None)]
    radii = [0.01, 0.005] if quick else [0.007, 0.005, 0.0035]
    r_half = radii[0] if quick else 0.005  # where the damping is halved (ten runs each)
    closed = closed_container(cfg.to_dict(), LOCK_RHO[1])
    closed_cfg = SPHConfig.from_dict(closed)
    res = {r: lock_exchange_ensemble(r, closed_cfg,
                                     DAMPING_SEEDS if r == r_half else ENSEMBLE_SEEDS)
           for r in radii}
    low = lock_exchange_ensemble(r_half, _halved_damping(closed), DAMPING_SEEDS)
    off = lock_exchange_run(r_half, SPHConfig.from_dict({**closed, "xsph": 0.0, "viscosity": 0.0}))
    band = lambda fr: bool(abs(fr / 0.5 - 1.0) <= 0.15)  # noqa: E731
    rows = []
    for r, d in res.items():
        c = f"lock exchange 1.5:1 2D (N={d['n']}, r={r * 1000:g} mm)"
        fh, fl = d["fr_heavy"], d["fr_light"]
        ens = f"mean of {d['runs']} starts"
        rows_deep = current_rows(r, d["H"])
        judged = rows_deep >= LOCK_RESOLVED_ROWS
        tol = "±15 %" if judged else (f"±15 %; info: {rows_deep:.0f} rows per current, "
                                      f"{LOCK_RESOLVED_ROWS} resolve it")
        rows += [Row(c, f"Fr heavy front (floor), {ens}", fh, "0.5", tol,
                     band(fh) if judged else None),
                 Row(c, f"Fr light front (lid), {ens}", fl, "0.5", tol,
                     band(fl) if judged else None),
                 Row(c, "Fr spread over the starts, heavy", d["spread_heavy"], "-",
                     f"light {d['spread_light']:.3f}; info", None),
                 Row(c, "front travel from the middle [m]", d["reach"], f"< {LOCK_L / 2 - LOCK_H:.2f}",
                     "info", None),
                 Row(c, "Re = UH/ν of XSPH + viscosity (U = ½ sqrt(g'H))",
                     _damping_reynolds(closed_cfg, r, d), "≳ 1000 for Fr ≈ ½", "info", None),
                 Row(c, "wall time [s], all starts", d["wall"], "-", "info", None)]
    c = f"lock exchange 1.5:1 2D (r={r_half * 1000:g} mm)"
    dh = low["heavy"] / res[r_half]["heavy"] - 1.0
    dl = low["light"] / res[r_half]["light"] - 1.0
    rows += [Row(c, f"heavy speed change, xsph & viscosity / 2, mean of {low['runs']} starts",
                 dh, "0", "< 5 %", bool(abs(dh) < 0.05)),
             Row(c, "light speed change, xsph & viscosity / 2", dl, "0", "info", None),
             Row(c, "Fr heavy / light, xsph & viscosity off", off["fr_heavy"], "0.5",
                 f"light {off['fr_light']:.3f}; info", None)]
    given = lock_exchange_run(r_half, cfg)
    given_half = lock_exchange_run(r_half, _halved_damping(cfg.to_dict()))
    rows += [Row(c, "Fr heavy / light, given settings as they are", given["fr_heavy"], "0.5",
                 f"light {given['fr_light']:.3f}; info", None),
             Row(c, "heavy speed change, same, xsph & viscosity / 2",
                 given_half["heavy"] / given["heavy"] - 1.0, "0", "info", None)]
    if len(radii) == 3:
        u = [res[r]["fr_heavy"] for r in radii]  # Fr: the depth is rounded to whole rows per radius
        d_coarse, d_fine = abs(u[1] - u[0]), abs(u[2] - u[1])
        rel = d_fine / abs(u[2])
        mm = " / ".join(f"{r * 1000:g}" for r in radii)
        c = f"lock exchange 1.5:1 2D (r = {mm} mm)"
        rows.append(Row(c,
                        f"heavy speed change {radii[1] * 1000:g} -> {radii[2] * 1000:g} mm", rel,
                        f"< {d_coarse / abs(u[2]):.3f} ({radii[0] * 1000:g} -> {radii[1] * 1000:g})",
                        "smaller, or < 5 %", bool(d_fine < d_coarse or rel < 0.05)))
        for k in ("heavy", "light"):
            fr, se = [res[r][f"fr_{k}"] for r in radii], [res[r][f"se_{k}"] for r in radii]
            a1, e1 = extrapolate_to_zero(radii, fr, se, order=1)
            a2, e2 = extrapolate_to_zero(radii, fr, se, order=2)
            rows += [Row(c, f"Fr {k}, extrapolated to r -> 0 (weighted line in r)", a1, "0.5",
                         f"±15 % (± {e1:.3f} from the starts)", band(a1)),
                     Row(c, f"Fr {k}, extrapolated to r -> 0 in r² (second order)", a2, "0.5",
                         f"± {e2:.3f}; info", None)]
    return rows


FILM = {"W": 0.6, "thickness": 0.02, "amplitude": 0.01, "wavelength": 0.2, "deep": 0.3,
        "shallow": 0.12, "T": 1.0, "span": 0.06}


def film_rise(dim: int, r: float, cfg: SPHConfig, depth: float, T: float = FILM["T"],
              ratio: float = 2.0) -> dict:
    """A film of light fluid (1000) on the floor under a ``ratio``:1 heavier one filled to
    ``depth``, the film's top perturbed by a cosine (``FILM``): how far the light phase's
    mean height rises in ``T`` s, and the share of it still within the film."""
    f = FILM
    size = _depth_size(dim, f["W"], depth + 0.05, f["span"])

    def fill(p):  # light below the perturbed film top, heavy above it up to ``depth``
        top = f["thickness"] + f["amplitude"] * np.cos(2 * np.pi * p[:, 0] / f["wavelength"])
        return np.where(p[:, 1] > depth, -1, np.where(p[:, 1] < top, 1, 0))

    sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), fill)],
                     [Phase("heavy", 1000.0 * ratio), Phase("light", 1000.0)], name="film")
    light = sy.phase == 1
    y0 = float(sy.x[light, 1].mean())
    run(Simulator(sy, cfg), T)
    y = sy.x[light, 1]
    return {"n": sy.n_fluid, "rise": float(y.mean()) - y0,
            "left": float(np.mean(y < f["thickness"] + f["amplitude"] + r))}


def film_ratio_ok(ratio: float) -> bool:
    """The thin-film check: the rise under the deep layer over that under the shallow one
    is 1 within a factor 1.5 (:func:`thin_film`)."""
    return bool(2 / 3 <= ratio <= 1.5)


def film_pair(dim: int, r: float, cfg: SPHConfig) -> dict:
    """:func:`film_rise` under the deep and the shallow layer of ``FILM``, and the ratio of
    the rises (deep / shallow; 0 when the shallow film does not rise)."""
    deep, shallow = (film_rise(dim, r, cfg, FILM[k]) for k in ("deep", "shallow"))
    ratio = deep["rise"] / shallow["rise"] if shallow["rise"] > 0 else 0.0
    return {"deep": deep, "shallow": shallow, "ratio": ratio}


def thin_film(dim: int, quick: bool, cfg: SPHConfig) -> list[Row]:
    """Rayleigh-Taylor of a thin light film on a floor, under a deep and a shallow layer.

    The film (2 cm, 2:1, top perturbed with amplitude 1 cm, wavelength 0.2 m) is unstable and
    rises. Both depths (0.3 and 0.12 m) are many times 1/k = 3.2 cm, and in an incompressible
    fluid the level of the pressure does not enter the motion, so the film must rise alike
    under both (ratio 1, ± 50 % for the surface, which the shallow plumes reach sooner). The
    pair-sum pressure force's lattice stiffness grows with the pressure (docs/sph.md, "Why
    light fluid stays under heavy fluid"): this row measures it.

    The 2-D film is not coarsened in the quick table: one row thick (r = 10 mm) it rises
    under neither depth, a resolution limit of its own (a light particle in the floor row
    can rise only by trading places with a heavy one, which the incompressible packing
    forbids; docs/sph.md, "The film one particle thick"); 1⅓ and 1.4 rows give ratios
    0.49-0.97 and 0.70-1.03 over six starts, two rows (r = 5 mm) 0.93-1.22. The 3-D film one
    row thick rises (0.84), so the 3-D quick row keeps r = 10 mm."""
    r = 0.005 if dim == 2 else (0.01 if quick else 0.0075)
    runs = film_pair(dim, r, cfg)
    ratio = runs["ratio"]
    c = f"thin film 2:1 {dim}D (N={runs['deep']['n']}/{runs['shallow']['n']}, {FILM['T']:g} s)"
    rows = [Row(c, "rise under 0.3 m / under 0.12 m", ratio, "1", "0.67-1.5",
                film_ratio_ok(ratio))]
    for k in ("deep", "shallow"):
        rows += [Row(c, f"rise of the light phase [mm], {k}", 1e3 * runs[k]["rise"], "", "info", None),
                 Row(c, f"light still in the film, {k}", runs[k]["left"], "", "info", None)]
    return rows


CASES = {
    "hydrostatic": hydrostatic,
    "dam_break": dam_break,
    "side_by_side": side_by_side,
    "side_by_side_2to1": lambda dim, quick, cfg: side_by_side(dim, quick, cfg, ratio=2.0),
    "high_ratio": high_ratio,
    "rayleigh_taylor": rayleigh_taylor,
    "four_phase": four_phase,
    "laplace": laplace,
    "lock_exchange": lock_exchange,
    "thin_film": thin_film,
}
