"""Neural rollout: a learned network advancing a :class:`~dcdc.particles.ParticleSystem`.

:class:`NeuralSimulator` has the interface of the SPH :class:`dcdc.sph.solver.Simulator`::

    sim = NeuralSimulator(model, system)       # a CorrectionNet or a checkpoint path
    sim.advance(0.02)                          # k network steps of the model's Δt
    sim.time, sim.stats, sim.system.x

Each step is Algorithm 1 of the paper (:func:`dcdc.model.integrator.step`) at the Δt the
network was trained for; the system's dimension, particle radius and Δt must
match the network's (:func:`dcdc.model.checkpoint.check_compatible`). Emitters work as in the
SPH solver: a particle with ``birth > t`` is inactive — neither stepped nor a neighbour —
until its birth time, then it starts from its stored position and velocity.

The stability guard (:class:`Guard`) checks the state after every step and stops the
rollout with :class:`RolloutStopped` (a one-line report of step, particle and cause) when it
turns NaN/inf, a particle exceeds the speed bound, leaves the domain, or more than a
fraction of the particles sits inside walls (:func:`dcdc.metrics.inside_walls`). Wall
penetrations are counted in ``stats`` either way.

Wall contact (``contact=True``): after each network step, a particle that has
reached a wall's solid is moved back to its surface and loses its velocity into the wall —
the SPH solver's own inelastic, frictionless contact (:meth:`dcdc.sph.volume_map.VolumeMap.
keep_outside`, on the walls' volume map built from the scene's signed distance or the wall
particles). It is a hard constraint, not learned: the network still does all the fluid
dynamics, and ``stats["contacts"]`` counts the particles it moved. The networks of
DeepLagrangianFluids and of the paper have no such step; ``contact=False`` (``dcdc simulate
--no-contact``) rolls out the network alone, and docs/models.md reports both. The default
(``contact=None``) is the model's own (:func:`uses_contact`): a checkpoint states whether its
network runs alone (``"contact": false``, measured on the generalisation suite and the
showcases) or needs the contact (``true``, the default of a checkpoint that says nothing).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import torch

from ..errors import DcdcError, SimulationDiverged
from ..metrics import inside_walls, wall_grid
from ..particles import ParticleSystem
from . import CONTACT_DEFAULT


@dataclass
class Guard:
    """Bounds of a rollout that counts as stable (docs/evaluation.md, "Metric definitions":
    steps to failure).

    max_speed: a particle faster than this [m/s] is an explosion (the SPH solver's bound).
    max_in_walls: the largest fraction of active particles allowed inside walls (0 stops at
        the first penetrating particle, 1 never stops for walls).
    check_domain: stop when a particle leaves ``system.domain``.
    """

    max_speed: float = 50.0
    max_in_walls: float = 0.01
    check_domain: bool = True

    def __post_init__(self):
        if not (math.isfinite(self.max_speed) and self.max_speed > 0):
            raise DcdcError(f"guard max_speed must be a finite number > 0 (got {self.max_speed})")
        if not (0.0 <= self.max_in_walls <= 1.0):
            raise DcdcError(f"guard max_in_walls must lie in [0, 1] (got {self.max_in_walls})")


class RolloutStopped(SimulationDiverged):
    """The guard stopped a rollout: ``step`` (1-based, the step that failed), ``particle``
    (index into the system's fluid particles), ``cause`` (nan | speed | domain | walls)."""

    def __init__(self, step: int, t: float, particle: int, cause: str, detail: str):
        self.step, self.time, self.particle, self.cause = step, t, particle, cause
        super().__init__(f"neural rollout stopped at step {step} (t = {t:.3f} s): "
                         f"particle #{particle} {detail}")


def uses_contact(model, contact: bool | None = None) -> bool:
    """``contact`` where given, else the network's own default: ``model.contact_default``,
    set from its checkpoint's ``"contact"`` by :func:`~dcdc.model.checkpoint.load_checkpoint`
    (True for a network or checkpoint that does not say)."""
    return bool(getattr(model, "contact_default", True)) if contact is None else bool(contact)


def _as_model(model, device):
    from ..model.checkpoint import load_checkpoint
    from ..model.networks import CorrectionNet

    if isinstance(model, CorrectionNet):
        return model
    if isinstance(model, (str, bytes)) or hasattr(model, "__fspath__"):
        return load_checkpoint(model, device=device)[0]
    raise DcdcError(f"NeuralSimulator needs a network or a checkpoint path "
                    f"(got {type(model).__name__})")


class NeuralSimulator:
    """A learned simulator with the SPH :class:`~dcdc.sph.solver.Simulator` interface.

    Args:
        model: a :class:`~dcdc.model.networks.CorrectionNet` or a checkpoint path.
        system: the initial state (advanced in place, like the SPH solver does).
        guard: the stability bounds (:class:`Guard`).
        time: simulated time of ``system`` (e.g. ``Trajectory.time[frame]``; emitters).
        density: optional per-particle rest densities [N] overriding the phases'.
        device: where the network runs ("cpu", "cuda").
        contact: apply the walls' contact after each step (module doc); None: the model's
            own default (:func:`uses_contact`), in ``self.uses_contact``.
    """

    def __init__(self, model, system: ParticleSystem, guard: Guard | None = None, time: float = 0.0, density=None,
                 device: str | torch.device = "cpu", contact: bool | None = CONTACT_DEFAULT):
        from ..model.checkpoint import check_compatible

        if not isinstance(system, ParticleSystem):
            raise DcdcError(f"NeuralSimulator needs a ParticleSystem (got {type(system).__name__})")
        self.model = _as_model(model, device).to(device).eval()
        cfg = self.model.cfg
        check_compatible(self.model, dim=system.dim, radius=system.radius,
                         what=f"the system {system.name!r}")
        self.dt = float(cfg.frame_dt)
        rho = system.rest_density if density is None else np.asarray(density, dtype=np.float64)
        if rho.shape != (system.n_fluid,):
            raise DcdcError(f"density has {rho.size} values for {system.n_fluid} particles")
        if system.n_fluid and not (np.isfinite(rho).all() and (rho > 0).all()):
            raise DcdcError("densities must be finite and > 0 (kg/m³)")
        system.check_finite()
        self.system = system
        self.density = rho
        self.guard = guard or Guard()
        self.time = float(time)
        self.steps = 0
        self.device = torch.device(device)
        self._wall_x = torch.as_tensor(system.wall_x)
        self._wall_n = torch.as_tensor(system.wall_n)
        self._gravity = torch.as_tensor(system.gravity)
        self.uses_contact = uses_contact(self.model, contact)
        self.contact = WallContact(system) if self.uses_contact and system.n_wall else None
        self.stats: dict = {}
        self.totals = {"steps": 0, "step_seconds": 0.0, "max_in_walls": 0, "max_speed": 0.0,
                       "contacts": 0}
        self.contacts: list[int] = []  # particles the wall contact moved in each step
        self.in_walls: list[int] = []  # particles inside walls after each step
        self.entered = np.zeros(system.n_fluid, dtype=bool)  # ever inside a wall
        self._wall_grid = wall_grid(system.wall_x, system.spacing) if system.n_wall else None
        self.step_ms: list[float] = []  # wall time of each completed step [ms]

    @classmethod
    def from_checkpoint(cls, path, system: ParticleSystem, **kw) -> "NeuralSimulator":
        return cls(path, system, **kw)

    # ------------------------------------------------------------------ stepping
    def active(self) -> np.ndarray:
        """Boolean mask of the particles taking part now: born and not removed
        (:meth:`~dcdc.particles.ParticleSystem.active`)."""
        return self.system.active(self.time)

    def step(self) -> dict:
        """One network step of Δt; returns ``self.stats``; raises :class:`RolloutStopped`."""
        from ..model.integrator import step

        sy = self.system
        act = self.active()
        idx = np.flatnonzero(act)
        t0 = time.perf_counter()
        if len(idx):
            with torch.no_grad():
                x, v = step(self.model, sy.x[idx], sy.v[idx], self.density[idx],
                            self._wall_x, self._wall_n, self.dt, self._gravity)
            x = x.detach().cpu().double().numpy()
            v = v.detach().cpu().double().numpy()
            n_contact = (self.contact.apply(x, v, sy.x[idx]) if self.contact is not None
                         else 0)
            sy.x[idx], sy.v[idx] = x, v
        else:
            n_contact = 0
        dt_wall = time.perf_counter() - t0
        self.contacts.append(n_contact)
        self.time += self.dt
        self.steps += 1
        n_in = self._check(idx)
        speed = float(np.sqrt((sy.v[idx] ** 2).sum(1)).max()) if len(idx) else 0.0
        self.stats = {"time": self.time, "steps": 1, "active": int(len(idx)),
                      "max_speed": speed, "in_walls": n_in, "contacts": n_contact,
                      "ms_per_step": 1e3 * dt_wall}
        t = self.totals
        t["contacts"] += n_contact
        t["steps"] += 1
        t["step_seconds"] += dt_wall
        t["max_in_walls"] = max(t["max_in_walls"], n_in)
        t["max_speed"] = max(t["max_speed"], speed)
        self.step_ms.append(1e3 * dt_wall)
        return self.stats

    def advance(self, frame_dt: float) -> dict:
        """Advance by ``frame_dt`` seconds, a whole number of network steps; returns the
        stats of the frame (as the SPH ``Simulator.advance``)."""
        if not (isinstance(frame_dt, (int, float)) and math.isfinite(frame_dt) and frame_dt > 0):
            raise DcdcError(f"frame dt must be a finite number > 0 (got {frame_dt!r})")
        k = round(frame_dt / self.dt)
        if k < 1 or abs(k * self.dt - frame_dt) > 1e-6 * frame_dt:
            raise DcdcError(f"frame dt {frame_dt:g} s is not a multiple of the model's step "
                            f"{self.dt:g} s")
        ms, n_in, vmax, n_c = 0.0, 0, 0.0, 0
        for _ in range(k):
            st = self.step()
            ms += st["ms_per_step"]
            n_in, vmax = st["in_walls"], max(vmax, st["max_speed"])
            n_c += st["contacts"]
        self.stats = {**self.stats, "steps": k, "max_speed": vmax, "in_walls": n_in,
                      "contacts": n_c, "ms_per_step": ms / k}
        return self.stats

    def run(self, duration: float, frame_dt: float | None = None, callback=None) -> None:
        """Advance ``duration`` seconds in frames of ``frame_dt`` (default one step);
        ``callback(sim)`` after each frame (as the SPH ``Simulator.run``)."""
        frame_dt = self.dt if frame_dt is None else frame_dt
        for _ in range(max(1, int(round(duration / frame_dt)))):
            self.advance(frame_dt)
            if callback is not None:
                callback(self)

    # ------------------------------------------------------------------ guard
    def _check(self, idx: np.ndarray) -> int:
        """Guard after a step; returns the number of particles inside walls."""
        sy, g = self.system, self.guard
        if not len(idx):
            self.in_walls.append(0)
            return 0
        x, v = sy.x[idx], sy.v[idx]
        bad = ~(np.isfinite(x).all(1) & np.isfinite(v).all(1))
        if bad.any():
            i = int(idx[np.flatnonzero(bad)[0]])
            raise RolloutStopped(self.steps, self.time, i, "nan",
                                 f"turned NaN/inf ({int(bad.sum())} particle(s))")
        speed = np.sqrt((v ** 2).sum(1))
        j = int(np.argmax(speed))
        if speed[j] > g.max_speed:
            raise RolloutStopped(self.steps, self.time, int(idx[j]), "speed",
                                 f"moves at {speed[j]:.3g} m/s, above the bound "
                                 f"{g.max_speed:g} m/s")
        if g.check_domain:
            lo, hi = sy.domain
            out = ~((x >= lo) & (x <= hi)).all(1)
            if out.any():
                k = int(np.flatnonzero(out)[0])
                raise RolloutStopped(self.steps, self.time, int(idx[k]), "domain",
                                     f"left the domain at {np.round(x[k], 3).tolist()} "
                                     f"({int(out.sum())} particle(s) outside)")
        inside = inside_walls(x, sy.wall_x, sy.wall_n, sy.spacing, grid=self._wall_grid)
        n_in = int(inside.sum())
        self.in_walls.append(n_in)
        self.entered[idx[inside]] = True
        if n_in > g.max_in_walls * len(idx):
            k = int(np.flatnonzero(inside)[0])
            raise RolloutStopped(self.steps, self.time, int(idx[k]), "walls",
                                 f"is inside a wall at {np.round(x[k], 3).tolist()} "
                                 f"({n_in} of {len(idx)} particles in walls, more than "
                                 f"{g.max_in_walls:g} of them)")
        return n_in


class WallContact:
    """The neural rollout's wall contact (module doc) on the walls' volume map that the SPH
    solver would build (its default kernel support h).

    A particle is caught when its Ψ exceeds the flat-wall value at ``catch`` particle radii
    from the wall surface (0.1 r: Ψ ≈ 0.41) and put back where Ψ equals the flat-wall value
    at ``release`` radii (r/2: Ψ ≈ 0.29; the first fluid row at rest sits at r, Ψ ≈ 0.16).
    Fluid at rest is never caught — Ψ is at most 0.30 in a 2-D corner and 0.39 in a 3-D one
    (measured on the built-in scenes) — and a caught particle is left r/2 off the wall, well
    outside the rollout guard's test (:func:`dcdc.metrics.inside_walls`)."""

    def __init__(self, system: ParticleSystem, catch: float = 0.1, release: float = 0.5):
        from ..sph.config import SPHConfig
        from ..sph.kernels import lattice_volume
        from ..sph import volume_map as vm

        r, d = system.radius, system.dim
        h = SPHConfig().support * r
        V0 = lattice_volume(2.0 * r, h, d)
        self.map = vm.for_system(system, h, V0)
        self.radius = r
        z, psi = vm.half_space_profile(h, d)
        off = vm.wall_offset(r, h, d, V0)
        # Ψ decreases with the distance z from the map's surface, which lies off behind the walls'
        self.limit = float(np.interp((catch * r + off), z, psi))
        self.target = float(np.interp((release * r + off), z, psi))

    def apply(self, x: np.ndarray, v: np.ndarray, x_old: np.ndarray | None = None) -> int:
        """Move the caught particles of ``x``/``v`` in place; returns how many. With the
        positions before the step, ``x_old``, a particle that moved more than r/2 is also
        caught where its straight path first enters a wall (sampled every r/2), so a fast one
        cannot jump through a thin wall (a lid one particle thick) within a step."""
        if self.map is None:
            return 0
        if x_old is not None:
            self._sweep(x, x_old)
        return self.map.keep_outside(x, v, limit=self.limit, target=self.target)

    def _sweep(self, x: np.ndarray, x_old: np.ndarray) -> None:
        step = 0.5 * self.radius
        d = x - x_old
        length = np.sqrt((d ** 2).sum(1))
        fast = np.flatnonzero(length > step)
        if not len(fast):
            return
        n = int(np.ceil(length[fast].max() / step))
        t = np.arange(1, n + 1) / n  # points along each path, the end included
        pts = x_old[fast, None, :] + t[None, :, None] * d[fast, None, :]
        psi, _ = self.map.sample(pts.reshape(-1, x.shape[1]))
        inside = psi.reshape(len(fast), n) > self.limit
        hit = inside.any(1)
        first = inside.argmax(1)
        # the first point inside: keep_outside then moves it back to the release level
        x[fast[hit]] = pts[np.flatnonzero(hit), first[hit]]


def _check_memory(frames: int, n: int, dim: int) -> None:
    """Refuse, before allocating, frames that would not fit in half this machine's memory."""
    from ..scene.budget import physical_memory

    need = 2.0 * frames * n * dim * 4  # float32 positions + velocities
    mem = physical_memory()
    if mem and need > 0.5 * mem:
        raise DcdcError(f"{frames} frames of {n} particles need {need / 2**30:.1f} GiB, more "
                        f"than half of this machine's {mem / 2**30:.1f} GiB; use fewer --steps")


@dataclass
class Rollout:
    """Frames of a rollout: positions/velocities [T, N, d] (frame 0 = the start), times [T],
    the particles inside walls after each step [T − 1], and the guard's report if it stopped
    (then the frames end with the last state before the failing step). ``ms_per_step`` is
    the median wall time of a step (the first, which compiles kernels, does not skew it)."""

    position: np.ndarray
    velocity: np.ndarray
    time: np.ndarray
    in_walls: np.ndarray
    stopped: RolloutStopped | None
    ms_per_step: float
    contacts: np.ndarray | None = None  # particles the wall contact moved in each step [T − 1]
    entered_walls: int = 0  # distinct particles inside a wall after any step of the simulator
    sph_frames: int = 0  # leading frames copied from an SPH run, not stepped (demo --settle)

    @property
    def steps(self) -> int:
        """Network steps completed without a guard stop (SPH frames before them excluded)."""
        return len(self.time) - 1 - self.sph_frames


def run(sim: NeuralSimulator, n_steps: int, progress=None, interrupt_check=None) -> Rollout:
    """``n_steps`` steps of ``sim``, keeping every frame. A guard stop ends the rollout early
    (it is recorded, not raised). ``progress(1)`` after each step."""
    if not (isinstance(n_steps, (int, np.integer)) and n_steps >= 1):
        raise DcdcError(f"a rollout needs at least 1 step (got {n_steps!r})")
    sy = sim.system
    _check_memory(n_steps + 1, sy.n_fluid, sy.dim)
    xs = np.empty((n_steps + 1,) + sy.x.shape, dtype=np.float32)
    vs = np.empty_like(xs)
    ts = np.empty(n_steps + 1)
    xs[0], vs[0], ts[0] = sy.x, sy.v, sim.time
    stopped, k = None, 0
    first, first_w, first_c = len(sim.step_ms), len(sim.in_walls), len(sim.contacts)
    for k in range(1, n_steps + 1):
        try:
            sim.step()
        except RolloutStopped as e:
            stopped, k = e, k - 1
            break
        xs[k], vs[k], ts[k] = sy.x, sy.v, sim.time
        if interrupt_check is not None:
            interrupt_check()
        if progress is not None:
            progress(1)
    n = k + 1
    ms = sim.step_ms[first:]
    walls = sim.in_walls[first_w:first_w + k]
    contacts = np.asarray(sim.contacts[first_c:first_c + k], dtype=np.int64)
    return Rollout(xs[:n], vs[:n], ts[:n], np.asarray(walls, dtype=np.int64), stopped,
                   float(np.median(ms)) if ms else float("nan"), contacts,
                   int(sim.entered.sum()))


def write_rollout(path, name: str, ro: Rollout, system: ParticleSystem, attrs: dict,
                  steps_requested: int | None = None):
    """Write a rollout in the dataset layout (docs/datasets.md) with
    :func:`dcdc.data.dataset.write_trajectory` (atomic), so :class:`~dcdc.data.dataset.Dataset`,
    ``dcdc render`` and ``dcdc export`` read it. The guard's verdict and the wall
    penetrations per step go into ``solver_stats``; the attributes ``rollout_status``
    ("finished" or "stopped"), ``steps``, ``steps_requested`` and ``stopped`` (the guard's
    one-line reason, "" when finished) say whether the file holds the whole run asked for:
    a stopped rollout is a partial result and says so (``dcdc dataset info`` shows it).
    A rollout stopped before its first step is not written (:class:`RolloutStopped`)."""
    import json

    from ..data.dataset import write_trajectory

    st = ro.stopped
    if ro.steps == 0 and st is not None:
        raise st
    asked = ro.steps if steps_requested is None else int(steps_requested)
    stats = {"steps": ro.steps, "sph_frames": ro.sph_frames, "ms_per_step": ro.ms_per_step,
             "in_walls": ro.in_walls.tolist(),
             "in_walls_max": int(ro.in_walls.max()) if len(ro.in_walls) else 0,
             "contacts": [] if ro.contacts is None else ro.contacts.tolist(),
             "stopped": str(st) if st else "", "stop_cause": st.cause if st else "",
             "stop_step": st.step if st else -1, "stop_particle": st.particle if st else -1}
    meta = {**attrs, "solver_stats": json.dumps(stats), "duration": float(ro.time[-1] - ro.time[0]),
            "rollout_status": "stopped" if st else "finished", "steps": ro.steps,
            "steps_requested": asked, "stopped": str(st) if st else ""}
    return write_trajectory(path, name, ro.position, ro.velocity, ro.time, system, meta)
