"""Public API of the reference solver: :class:`Simulator` advances a
:class:`~dcdc.particles.ParticleSystem` frame by frame with CFL-adaptive substeps.

    sim = Simulator(system, SPHConfig(solver="dfsph"))
    sim.advance(0.02)          # one frame; system.x / system.v are updated in place
    sim.time, sim.stats        # stats of the last frame
    sim.pressure(), sim.density()

DFSPH applies pressure twice per substep (the divergence-free and the constant-density
solve), and each solve's field also carries a one-substep correction of the density error
left by the previous one: a density error of 1e-4 spread over a 0.5 m tank needs a
correction of ~ρ0 L² 1e-4 / Δt² ≈ 10 kPa, as large as the hydrostatic pressure. The
physical pressure is the impulse-weighted mean of their sum, which is what
:meth:`Simulator.pressure` returns (docs/sph.md, "Reading the pressure"; measured on a
2-D tank at rest: fitted slope 1.02 ρ0 g for this mean, 0.95 for the last solve's field
sampled once a frame, which swings between 0.2 and 1.1 from substep to substep).

Particles with ``system.birth > sim.time`` are inactive (neither simulated nor neighbours)
until their birth time; then they start at their stored position and velocity. With
``on_escape = "remove"`` a particle that leaves ``system.domain`` is removed at the end of
that substep: ``system.death`` gets the time, and from then on it is inactive like an
unborn one, frozen at its last position and velocity (active: ``birth <= t < death``).
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..errors import DcdcError, SimulationDiverged
from ..neighbors import CellGrid
from ..particles import TIME_EPS, ParticleSystem
from . import dfsph, volume_map, wcsph
from .boundary import check_fluid_outside_walls, wall_volumes
from .config import SPHConfig
from . import interfaces
from .kernels import lattice_volume
from .neighbourhood import build
from .reference import fill_level, reference_pressure, strata, surface_levels
from .state import State
from .terms import mixture_density, psi_gradient


class Simulator:
    """Multiphase SPH (DFSPH or WCSPH) on a :class:`ParticleSystem` (see module doc)."""

    def __init__(self, system: ParticleSystem, cfg: SPHConfig | None = None):
        if not isinstance(system, ParticleSystem):
            raise DcdcError(f"Simulator needs a ParticleSystem (got {type(system).__name__})")
        cfg = SPHConfig() if cfg is None else cfg
        if not isinstance(cfg, SPHConfig):
            raise DcdcError(f"Simulator needs an SPHConfig (got {type(cfg).__name__})")
        cfg.validate()
        _check_system(system)
        self.system = system
        self.cfg = cfg
        self.time = 0.0
        r = system.radius
        self.h = cfg.support * r
        self.V0 = lattice_volume(2.0 * r, self.h, system.dim)
        self.Vb = wall_volumes(system.wall_x, self.h, self.V0)
        self._walls = CellGrid(system.wall_x, self.h)  # static: binned once
        self.volume_map = (volume_map.for_system(system, self.h, self.V0, cfg.wall_buoyancy,
                                                  cfg.wall_contact_support)
                           if cfg.boundary == "map" else None)
        self._wall_edges = self.volume_map is None or cfg.no_slip
        self._rho0 = system.rest_density
        nu = system.viscosity + cfg.viscosity
        self._mu = self._rho0 * nu
        self._mu_cross = None if cfg.interface_damping else self._rho0 * system.viscosity
        n = system.n_fluid
        self._p = np.zeros(n)
        self._p_div = np.zeros(n)
        self._p_frame = np.zeros(n)  # Δt-weighted mean of p + p_div over the last frame
        self._sound_speed = cfg.sound_speed or _auto_sound_speed(system)
        C = interfaces.coefficients(cfg.interfacial_model, cfg.interfacial_tension,
                                    system.phases, self.h, self.V0, system.dim, cfg.wall_tension)
        self._interface = None if C is None else (cfg.interfacial_model, C)
        self._reference = None
        lightest = min(ph.density for ph in system.phases)
        auto = cfg.reference_surface or cfg.reference_stratified
        rho_ref = cfg.reference_density or (cfg.reference_share * lightest if auto else 0.0)
        if rho_ref > lightest:
            raise DcdcError(f"sph.reference_density ({cfg.reference_density:g}) exceeds the "
                            f"lightest phase's density ({lightest:g} kg/m³)")
        if rho_ref > 0 and np.any(system.gravity):  # without gravity q = 0: nothing to take out
            born = system.birth <= 0.0  # an emitter's particles count once they exist
            level = (fill_level(system.x[born] if born.any() else system.x, system.gravity, r)
                     if cfg.reference_level is None else cfg.reference_level)
            self._reference = (rho_ref, level, 0.0)
            self._fill = level  # reference_surface: the level while no particle is at a surface
        self._capillary_dt = capillary_dt(cfg, system)
        self.stats: dict = {}
        self.totals = {"frames": 0, "substeps": 0, "iterations": 0, "divergence_iterations": 0,
                       "max_density_error": 0.0, "removed": 0}

    def _follow(self, s, nbh) -> tuple:
        """This substep's reference (ρ_ref, L, slab thickness): L one diameter below the
        lowest surface particle of each particle's body of fluid (``reference_surface``: the
        surface's own rows, and the floor row under a thin surge, keep their full weight), ρ_ref
        per slab from the neighbours' kernel mixture densities (``reference_stratified``)."""
        rho_ref, level, dz = self._reference
        d = 2.0 * self.system.radius
        if self.cfg.reference_surface:
            level = surface_levels(s.x, psi_gradient(nbh.rs, nbh.G, nbh.Sb, self.V0), self.h,
                                   s.gravity, nbh.rs, nbh.idx, self._fill, margin=d)
        if self.cfg.reference_stratified and not self.cfg.reference_density:
            rho_bar = mixture_density(s.rho0, nbh.rs, nbh.idx, nbh.W, exclude_self=True)
            rho_ref, dz = strata(s.x, rho_bar, s.gravity, level, d, self.cfg.reference_share), d
        return rho_ref, level, dz

    # ------------------------------------------------------------------ stepping
    def advance(self, frame_dt: float) -> dict:
        """Advance by ``frame_dt`` seconds with CFL-adaptive substeps; returns ``self.stats``."""
        if not (isinstance(frame_dt, (int, float)) and math.isfinite(frame_dt) and frame_dt > 0):
            raise DcdcError(f"frame dt must be a finite number > 0 (got {frame_dt!r})")
        cfg = self.cfg
        t_end = self.time + frame_dt
        n_sub = 0
        its, its_div, dts = [], [], []
        max_err = 0.0
        n_active = 0
        n_removed = 0
        p_sum = np.zeros(self.system.n_fluid)
        while t_end - self.time > 1e-12 * max(1.0, t_end):
            active = self._active()
            s = self._state(active)
            n_active = len(s.x)
            if n_active == 0:
                self.time = t_end
                break
            nbh = self._neighbourhood(s)
            if self._reference is not None:
                self._reference = s.reference = self._follow(s, nbh)
            dt = self._choose_dt(s, t_end - self.time)
            if cfg.solver == "dfsph":
                info = dfsph.substep(s, nbh, dt, cfg)
            else:
                info = wcsph.substep(s, nbh, dt, cfg, self._sound_speed)
            if self.volume_map is not None:
                self.volume_map.keep_outside(s.x, s.v)
            self._store(active, s)
            p_total = s.p + s.p_div
            if self._reference is not None:
                p_total = p_total + reference_pressure(s.x, s.gravity, *self._reference)
            if active is None:
                p_sum += dt * p_total
            else:
                p_sum[active] += dt * p_total
            self.time += dt
            n_sub += 1
            its.append(info["iterations"])
            its_div.append(info["divergence_iterations"])
            dts.append(dt)
            max_err = max(max_err, float(np.maximum(nbh.psi - 1.0, 0.0).mean()))
            n_removed += self._check(s, active)
        if abs(self.time - t_end) < 1e-9:
            self.time = t_end
        alive = self.system.death > self.time + TIME_EPS  # the removed are gone
        self._p_frame = np.where(alive, p_sum / frame_dt, 0.0)  # 0 if removed in this frame
        v = self.system.v[alive]
        speed = np.sqrt((v ** 2).sum(1)).max() if len(v) else 0.0
        self.stats = {
            "time": self.time,
            "substeps": n_sub,
            "mean_dt": float(np.mean(dts)) if dts else 0.0,
            "min_dt": float(np.min(dts)) if dts else 0.0,
            "iterations": float(np.mean(its)) if its else 0.0,
            "divergence_iterations": float(np.mean(its_div)) if its_div else 0.0,
            "max_density_error": max_err,
            "max_speed": float(speed),
            "active": n_active,
            "removed": n_removed,
        }
        t = self.totals
        t["frames"] += 1
        t["substeps"] += n_sub
        t["iterations"] += int(np.sum(its))
        t["divergence_iterations"] += int(np.sum(its_div))
        t["max_density_error"] = max(t["max_density_error"], max_err)
        t["removed"] += n_removed
        return self.stats

    def run(self, duration: float, frame_dt: float = 0.02, callback=None) -> None:
        """Advance ``duration`` seconds in frames of ``frame_dt``; ``callback(sim)`` after each."""
        n = max(1, int(round(duration / frame_dt)))
        for _ in range(n):
            self.advance(frame_dt)
            if callback is not None:
                callback(self)

    # ------------------------------------------------------------------ fields
    def pressure(self) -> np.ndarray:
        """Pressure [Pa] of each fluid particle over the last frame: the Δt-weighted mean of
        the divergence-free and constant-density pressures of its substeps (WCSPH: of the
        equation of state), plus the reference pressure q where ``reference_density`` is
        set; 0 for inactive particles (module doc: why a mean)."""
        return self._p_frame.copy()

    def density(self) -> np.ndarray:
        """Number-density estimate ρ_i = ρ0_i ψ_i [kg/m³] at the current positions; NaN for
        inactive particles."""
        out = np.full(self.system.n_fluid, np.nan)
        active = self._active()
        s = self._state(active)
        if len(s.x):
            nbh = self._neighbourhood(s)
            out[active if active is not None else slice(None)] = s.rho0 * nbh.psi
        return out

    @staticmethod
    def threads() -> int:
        return nb.get_num_threads()

    # ------------------------------------------------------------------ internals
    def _neighbourhood(self, s: State):
        return build(s.x, self._walls, s.Vb, self.h, self.V0, self.volume_map, self._wall_edges)

    def _active(self):
        """Index array of active particles (born, not removed), or None when all are active
        (fast path)."""
        act = self.system.active(self.time)
        return None if act.all() else np.flatnonzero(act)

    def _state(self, active) -> State:
        sy = self.system
        sel = (lambda a: a) if active is None else (lambda a: a[active])
        return State(sel(sy.x), sel(sy.v), sel(sy.phase), sel(self._rho0), sel(self._mu),
                     sel(self._p), sel(self._p_div), sy.wall_x, self.Vb, sy.gravity, self.V0, self.h,
                     self._interface, (self.cfg.smagorinsky * 2.0 * sy.radius) ** 2,
                     None if self._mu_cross is None else sel(self._mu_cross), self._reference)

    def _store(self, active, s: State) -> None:
        if active is None:
            return  # the state holds views of the system arrays
        sy = self.system
        sy.x[active] = s.x
        sy.v[active] = s.v
        self._p[active] = s.p
        self._p_div[active] = s.p_div

    def _choose_dt(self, s: State, remaining: float) -> float:
        cfg = self.cfg
        vmax = float(np.sqrt((s.v ** 2).sum(1)).max())
        g = float(np.linalg.norm(s.gravity))
        if cfg.solver == "wcsph":
            vmax += wcsph.max_sound_speed(s.rho0, self._sound_speed)
        dx = cfg.cfl * 2.0 * self.system.radius
        dt = min(cfg.dt_max, dx / max(vmax, cfg.speed_floor), self._capillary_dt)
        if g > 0:  # a particle starting at rest must not cross cfl·2r within one substep either
            dt = min(dt, math.sqrt(2.0 * dx / g))
        if dt < cfg.dt_min:
            raise SimulationDiverged(f"substep fell below dt_min = {cfg.dt_min:g} s at "
                                     f"t = {self.time:.4f} s (max speed {vmax:.3g} m/s)")
        n = math.ceil(remaining / dt - 1e-9)
        return remaining / max(n, 1)

    def _check(self, s: State, active) -> int:
        """Stop on NaN, a speed above ``max_speed`` or (``on_escape = "error"``) a particle
        outside the domain; with "remove", mark those particles removed now. Returns how
        many were removed."""
        if not (np.isfinite(s.x).all() and np.isfinite(s.v).all()):
            bad = int((~np.isfinite(s.x).all(1) | ~np.isfinite(s.v).all(1)).sum())
            raise SimulationDiverged(f"simulation diverged: state turned NaN/inf at "
                                     f"t = {self.time:.4f} s for {bad} particle(s)")
        speed2 = (s.v ** 2).sum(1)
        vmax = math.sqrt(float(speed2.max()))
        if vmax > self.cfg.max_speed:
            raise SimulationDiverged(f"simulation exploded: speed {vmax:.3g} m/s exceeds "
                                     f"sph.max_speed = {self.cfg.max_speed:g} at t = {self.time:.4f} s")
        lo, hi = self.system.domain
        out = ~((s.x >= lo) & (s.x <= hi)).all(1)
        if not out.any():
            return 0
        if self.cfg.on_escape == "remove":
            gone = np.flatnonzero(out)
            self.system.death[gone if active is None else active[gone]] = self.time
            return len(gone)
        i = int(np.flatnonzero(out)[0])
        raise SimulationDiverged(f"{int(out.sum())} fluid particle(s) left the domain at "
                                 f"t = {self.time:.4f} s, e.g. at {np.round(s.x[i], 4).tolist()}")


def _check_system(sy: ParticleSystem) -> None:
    """Reject inputs that would give a traceback or a silently wrong run."""
    for ph in sy.phases:
        if not (math.isfinite(ph.density) and ph.density > 0):
            raise DcdcError(f"phase {ph.name!r} has density {ph.density}; it must be > 0")
        if not (math.isfinite(ph.viscosity) and ph.viscosity >= 0):
            raise DcdcError(f"phase {ph.name!r} has viscosity {ph.viscosity}; it must be >= 0")
    if sy.n_fluid == 0:
        raise DcdcError("the scene has no fluid particles")
    sy.check_finite()
    if not (np.isfinite(sy.wall_x).all() and np.isfinite(sy.wall_n).all()):
        raise DcdcError("wall particles or normals contain NaN/inf")
    if not np.isfinite(sy.gravity).all():
        raise DcdcError("gravity contains NaN/inf")
    if not np.isfinite(sy.birth).all():
        raise DcdcError("birth times contain NaN/inf")
    if np.isnan(sy.death).any():
        raise DcdcError("death (removal) times contain NaN (inf = never removed)")
    sy.check_inside_domain()
    check_fluid_outside_walls(sy.x, sy.wall_x, sy.wall_n, sy.spacing)


def capillary_dt(cfg: SPHConfig, system: ParticleSystem) -> float:
    """Brackbill et al.'s capillary bound on the substep, Δt < sqrt(ρ̄ Δx³ / (2πσ)), for the
    continuum tension models (:func:`dcdc.sph.interfaces.stable_dt`); "pairwise": inf."""
    if cfg.interfacial_model not in interfaces.CSF_MODELS:
        return math.inf
    return interfaces.stable_dt(cfg.interfacial_tension, system.phases, 2.0 * system.radius)


def rest_substep(cfg: SPHConfig, system: ParticleSystem) -> float:
    """The DFSPH substep of a fluid slower than ``speed_floor`` (docs/sph.md, "Substeps"):
    min(dt_max, cfl·2r / speed_floor, the capillary bound, sqrt(2·cfl·2r / |g|)); faster
    flow takes shorter ones."""
    dx = cfg.cfl * 2.0 * system.radius
    dt = min(cfg.dt_max, dx / cfg.speed_floor, capillary_dt(cfg, system))
    g = float(np.linalg.norm(system.gravity))
    return min(dt, math.sqrt(2.0 * dx / g)) if g > 0 else dt


def _auto_sound_speed(sy: ParticleSystem) -> float:
    """WCSPH speed of sound: 10 × the free-fall speed over the fluid's initial height."""
    g = float(np.linalg.norm(sy.gravity))
    up = -sy.gravity / g if g > 0 else np.eye(sy.dim)[1]
    height = float(np.ptp(sy.x @ up)) + sy.spacing if sy.n_fluid else sy.spacing
    return max(10.0 * math.sqrt(2.0 * max(g, 1.0) * height), 1.0)
