"""Experiment runners behind the validation's cases (:mod:`dcdc.sph.cases`) and the
benchmarks: the lock exchange (one start and an ensemble), two phases at a high density
ratio in a filled tank, the `laplace` drop, particle-size drops on a floor, a sessile drop and
the thin film. Each builds its set-up (:mod:`dcdc.sph.fixtures`), runs the solver and returns
its measurements (:mod:`dcdc.sph.measures`) as a dict."""
from __future__ import annotations

import math

import numpy as np

from ..particles import FRAME_DT, Phase
from .config import SPHConfig
from .fixtures import G, jitter, laplace_box, laplace_drop, laplace_half, tank_size, tank_system
from .forces import xsph_viscosity
from .measures import (ClosestPair, cap_contact_angle, drop_radius, exchange_fronts, front_speed,
                       layer_purity, max_radius_ratio, phase_order_ok, phase_volumes, run,
                       standard_error)
from .solver import Simulator


# lock exchange: tank, densities and the fit window in units of T0 = sqrt(H/g')
LOCK_L, LOCK_H = 1.6, 0.2
LOCK_RHO = (1500.0, 1000.0)
LOCK_WINDOW = (2.0, 5.0)


# the per-radius Froude rows are judged where each current (half the depth) is at least this
# many particle rows deep (h/H <= 0.1 with the support h = 2 spacings); coarser radii are
# reported as information: the fronts' shortfall from their speed extrapolated to r -> 0 is
# 17-20 % at 7 rows and 13-14 % at 10 (docs/sph.md, "Closed containers", "The resolution a
# current needs")
LOCK_RESOLVED_ROWS = 10

ENSEMBLE_SEEDS = (0, 1, 2)  # the start at rest and two 1 mm/s random starts (:func:`jitter`)


# the lock exchange's damping check compares two ensemble means: one run's heavy front
# changes by 12 % (sd) between equal settings at 10 mm, so three starts leave ±7 % of noise
# on a 5 % tolerance; ten leave ±3.7 % (docs/sph.md, "Closed containers")
DAMPING_SEEDS = tuple(range(10))


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
    run(sim, window[1] * T0 + FRAME_DT, sample)
    heavy, light = front_speed(ts, xh), -front_speed(ts, xl)
    scale = math.sqrt(gp * H)
    return {"heavy": heavy, "light": light, "fr_heavy": heavy / scale, "fr_light": light / scale,
            "gp": gp, "T0": T0, "H": H, "reach": max(max(xh) - L / 2, L / 2 - min(xl)),
            "n": sy.n_fluid, "wall": time.perf_counter() - t0}


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
               se_heavy=standard_error([d["fr_heavy"] for d in runs]),
               se_light=standard_error([d["fr_light"] for d in runs]),
               reach=max(d["reach"] for d in runs), n=runs[0]["n"],
               wall=sum(d["wall"] for d in runs), runs=len(runs))
    return out


def damping_reynolds(cfg: SPHConfig, r: float, run: dict) -> float:
    """The lock exchange's Reynolds number UH/ν with ν the stabilisation's: XSPH as a
    viscosity (:func:`dcdc.sph.forces.xsph_viscosity`, at the speed-floor CFL substep) plus
    the artificial viscosity; U = ½ sqrt(g'H)."""
    dt = min(cfg.dt_max, cfg.cfl * 2.0 * r / cfg.speed_floor)
    nu = xsph_viscosity(cfg.xsph, r, cfg.support, dt, 2) + cfg.viscosity
    U = 0.5 * math.sqrt(run["gp"] * run["H"])
    return U * run["H"] / nu if nu > 0 else math.inf


def halved_damping(settings: dict) -> SPHConfig:
    """These solver settings with ``xsph`` and ``viscosity`` halved."""
    return SPHConfig.from_dict({**settings, "xsph": 0.5 * settings["xsph"],
                                "viscosity": 0.5 * settings["viscosity"]})


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
    size = tank_size(dim, W, H, 0.2)
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
    start = (math.sqrt(2) if dim == 2 else math.sqrt(3)) * laplace_half(dim) / R
    return {"jump": dp / ((1 if dim == 2 else 2) * sigma / R),
            "shape": max_radius_ratio(sy.x[drop], r, R),
            "start": start, "N": sy.n_fluid, "R": R}


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
    Simulator(sy, SPHConfig.from_dict(cfg if sigma > 0 else {})).run(T, FRAME_DT)
    rise = sy.x[light, 1] - y0
    return {"risen": float(np.mean(rise > 4 * r)), "median_rise_r": float(np.median(rise)) / r,
            "drops": int(light.sum()),
            "bond": 1300.0 * G * (2 * r) ** 2 / sigma if sigma > 0 else math.inf}


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
        sim.run(every, FRAME_DT)
        angles.append(cap_contact_angle(sy.x, sy.phase, 1, r))
    return {"theta": angles, "n": sy.n_fluid, "wall": time.perf_counter() - t0}


FILM = {"W": 0.6, "thickness": 0.02, "amplitude": 0.01, "wavelength": 0.2, "deep": 0.3,
        "shallow": 0.12, "T": 1.0, "span": 0.06}


def film_rise(dim: int, r: float, cfg: SPHConfig, depth: float, T: float = FILM["T"],
              ratio: float = 2.0) -> dict:
    """A film of light fluid (1000) on the floor under a ``ratio``:1 heavier one filled to
    ``depth``, the film's top perturbed by a cosine (``FILM``): how far the light phase's
    mean height rises in ``T`` s, and the share of it still within the film."""
    f = FILM
    size = tank_size(dim, f["W"], depth + 0.05, f["span"])

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
    is 1 within a factor 1.5 (:func:`dcdc.sph.cases.thin_film`)."""
    return bool(2 / 3 <= ratio <= 1.5)


def film_pair(dim: int, r: float, cfg: SPHConfig) -> dict:
    """:func:`film_rise` under the deep and the shallow layer of ``FILM``, and the ratio of
    the rises (deep / shallow; 0 when the shallow film does not rise)."""
    deep, shallow = (film_rise(dim, r, cfg, FILM[k]) for k in ("deep", "shallow"))
    ratio = deep["rise"] / shallow["rise"] if shallow["rise"] > 0 else 0.0
    return {"deep": deep, "shallow": shallow, "ratio": ratio}
