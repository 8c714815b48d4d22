"""The Python API: scenes, models, SPH runs and learned rollouts from a notebook.

```python
import dcdc
scene = dcdc.load_scene("lock_exchange")          # built-in name, .toml path or TOML text
truth = dcdc.run_sph(scene, dim=2, duration=1.0)  # the multiphase SPH solver
model = dcdc.load_model("dcdc2d")                 # shipped name or checkpoint path
pred = dcdc.simulate(model, scene, dim=2, steps=50)
print(pred.position.shape, pred.heights(), pred.order_ok())
pred.save("pred.h5")                              # dcdc render / export read it
```

Thin layers over the functions the command line uses (``dcdc demo``, ``dcdc generate``,
``dcdc simulate``): :meth:`dcdc.scene.Scene.realize`, :func:`dcdc.sph.run` (over
:class:`dcdc.sph.Simulator`), :func:`dcdc.model.checkpoint.load_checkpoint`,
:class:`dcdc.evaluate.rollout.NeuralSimulator` and :func:`dcdc.evaluate.rollout.run`.
Both simulators return a :class:`Run`. Documented with a runnable example in docs/api.md.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import DcdcError
from .particles import ParticleSystem, active_mask

__all__ = ["Run", "load_scene", "load_model", "run_sph", "rollout", "simulate"]


@dataclass
class Run:
    """Frames of one simulation (SPH or learned), in memory.

    ``position``/``velocity`` are float32 [T, N, d] (frame 0 = the start), ``time`` [T] in
    seconds; ``system`` is the state after the last frame (its walls, phases, birth and
    removal times); ``stopped`` is the rollout guard's report where a learned rollout
    stopped early (its frames then end with the last good state), else None."""

    name: str
    position: np.ndarray
    velocity: np.ndarray
    time: np.ndarray
    system: ParticleSystem
    solver: str
    stopped: str | None = None
    ms_per_step: float = math.nan
    attrs: dict = field(default_factory=dict, repr=False)

    @property
    def dim(self) -> int:
        return self.system.dim

    @property
    def n_frames(self) -> int:
        return len(self.time)

    @property
    def phase(self) -> np.ndarray:
        """Phase index of each fluid particle [N]."""
        return self.system.phase

    @property
    def phases(self) -> list:
        """The phases (name, density, ...), indexed by :attr:`phase`."""
        return self.system.phases

    def active(self, frame: int = -1) -> np.ndarray:
        """Particles present at ``frame`` (born, not removed) [N]."""
        return active_mask(self.system.birth, self.system.death, float(self.time[frame]))

    def heights(self, frame: int = -1, stat: str = "mean") -> dict[str, float]:
        """Height of each phase at ``frame`` (``stat``: "mean" = centre of mass, or
        "median"), by phase name (:func:`dcdc.metrics.phase_heights`)."""
        from .metrics import phase_heights
        h = phase_heights(self.position[frame], self.phase, len(self.phases), stat,
                          active=self.active(frame))
        return {p.name: float(h[k]) for k, p in enumerate(self.phases)}

    def order_ok(self, frame: int = -1) -> bool:
        """Every phase lies below every lighter one at ``frame`` (median heights; the check
        of ``dcdc demo``, :func:`dcdc.metrics.density_order_ok`)."""
        from .metrics import density_order_ok
        return bool(density_order_ok(self.position[frame], self.phase,
                                     [p.density for p in self.phases], "median",
                                     active=self.active(frame)))

    def save(self, path) -> Path:
        """Write the run as one HDF5 trajectory in the dataset layout (docs/datasets.md),
        atomically; ``dcdc render``, ``dcdc export`` and :class:`dcdc.data.Dataset` read it."""
        from .data.dataset import write_trajectory
        attrs = {"name": self.name, "solver": self.solver, "split": "api",
                 "duration": float(self.time[-1] - self.time[0]), **self.attrs}
        if len(self.time) > 1:
            attrs.setdefault("frame_dt", float(self.time[1] - self.time[0]))
        return write_trajectory(path, self.name, self.position, self.velocity, self.time,
                                self.system, attrs)


def load_scene(scene):
    """A :class:`dcdc.scene.Scene`: from a built-in name (``dcdc scene list``), a path to a
    ``.toml`` scene file (docs/scenes.md), TOML text (any string holding a newline), or a
    Scene (returned as it is). A malformed scene raises :class:`dcdc.errors.DcdcError`
    naming the field and line."""
    from .scene import Scene, get_scene, parse
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, str) and "\n" in scene:
        return parse(scene, "scene")
    return get_scene(scene)


def load_model(model="dcdc2d", device: str = "cpu"):
    """A learned simulator (:class:`dcdc.model.networks.CorrectionNet`, in eval mode) from a
    shipped name (``dcdc2d``, ``cconv2d``, ``antisym2d``, ``dcdc3d``, ``cconv3d``;
    docs/models.md) or a checkpoint path (``dcdc train``); a network is returned as it is."""
    from .model.networks import CorrectionNet
    if isinstance(model, CorrectionNet):
        return model
    from .model.checkpoint import load_checkpoint
    return load_checkpoint(model, device=device)[0]


def _progress(progress, total: int, unit: str):
    """A tqdm bar for ``progress=True``, None for False/None, a callable as it is."""
    if progress is True:
        from tqdm import tqdm
        return tqdm(total=total, unit=unit)
    return None


def run_sph(scene, dim: int | None = None, resolution: float = 1.0,
            duration: float | None = None, solver: dict | None = None,
            max_particles: float | None = None, progress: bool = False) -> Run:
    """Simulate ``scene`` (:func:`load_scene`) with the multiphase SPH solver, as
    ``dcdc generate`` / ``dcdc demo`` do: the ``dim``-D variant (default: the scene's) at
    length scale ``resolution``, for ``duration`` seconds (default: the scene's) in frames
    of the scene's ``frame_dt``, with the scene's ``[solver]`` table updated by ``solver``
    (keys of :class:`dcdc.sph.SPHConfig`). A diverging run raises
    :class:`dcdc.errors.SimulationDiverged`. The frames come from :func:`dcdc.sph.run`."""
    from .scene.budget import check_duration
    from .sph import SPHConfig, run

    sc = load_scene(scene)
    duration = sc.duration if duration is None else duration
    fdt = sc.frame_dt
    check_duration(duration, fdt, "duration")
    n = int(round(duration / fdt))
    system = sc.realize(dim=dim, resolution=resolution, frames=n + 1,
                        max_particles=max_particles)
    settings = {**sc.solver, **(solver or {})}
    cfg = SPHConfig.from_dict(settings)
    sc.check_solver()  # the tension tables' phase names
    bar = _progress(progress, n, "frame")
    t0 = _time.perf_counter()
    try:
        xs, vs, times = run(system, cfg, n, fdt, progress=None if bar is None else bar.update)
    finally:
        if bar is not None:
            bar.close()
    wall = _time.perf_counter() - t0
    import json
    attrs = {"scene": sc.name, "scene_toml": sc.text, "scene_dim": sc.dim,
             "resolution": resolution, "frame_dt": fdt,
             "solver_settings": json.dumps(cfg.to_dict(), sort_keys=True), "wall_time_s": wall}
    return Run(f"{sc.name}_{system.dim}d", xs, vs, times, system,
               f"dcdc.sph ({cfg.solver})", None, 1e3 * wall / max(n, 1), attrs)


def rollout(model, system: ParticleSystem, steps: int, time: float = 0.0,
            contact: bool | None = None, device: str = "cpu", max_speed: float = 50.0,
            max_in_walls: float = 0.01, progress: bool = False) -> Run:
    """``steps`` steps of the learned simulator ``model`` (:func:`load_model`) from
    ``system`` (advanced in place; e.g. ``scene.realize(dim=2)`` or a dataset frame,
    ``Trajectory.system(frame)``, at simulated ``time``), as ``dcdc simulate`` does: the
    walls' contact after each step where ``contact`` says (None: the model's own default,
    :func:`dcdc.evaluate.rollout.uses_contact`; off for ``dcdc2d`` and ``cconv2d``), and a guard (``max_speed``
    m/s, ``max_in_walls`` fraction) that ends the rollout early with its report in
    :attr:`Run.stopped`."""
    from .evaluate.rollout import Guard, NeuralSimulator, run

    net = load_model(model, device)
    sim = NeuralSimulator(net, system, guard=Guard(max_speed=max_speed, max_in_walls=max_in_walls),
                          time=time, device=device, contact=contact)
    bar = _progress(progress, steps, "step")
    try:
        ro = run(sim, steps, progress=None if bar is None else bar.update)
    finally:
        if bar is not None:
            bar.close()
    return Run(f"{system.name}_{system.dim}d", ro.position, ro.velocity, ro.time, sim.system,
               f"dcdc.neural ({net.name})", None if ro.stopped is None else str(ro.stopped), ro.ms_per_step,
               {"frame_dt": sim.dt, "wall_contact": int(sim.uses_contact)})


def simulate(model, scene, dim: int | None = None, resolution: float = 1.0,
             steps: int | None = None, settle: float | None = None, contact: bool | None = None,
             device: str = "cpu", max_particles: float | None = None,
             progress: bool = False) -> Run:
    """Run the learned simulator ``model`` on ``scene`` (:func:`load_scene`) from its
    lattice start, as ``dcdc simulate --scene`` does: the ``dim``-D variant (default: the
    scene's; a 3-D scene runs in the model's dimension), ``steps`` network steps (default:
    the scene's duration). ``settle``: the scene's SPH solver runs the first ``settle``
    seconds and the network starts from that state (the frames start there)."""
    from .evaluate.start import settle_frames
    from .model.checkpoint import check_compatible
    from .sph import Simulator

    net = load_model(model, device)
    sc = load_scene(scene)
    if dim is None:
        dim = net.dim if sc.dim == 3 else sc.dim
    check_compatible(net, dim=int(dim), frame_dt=sc.frame_dt, what=f"scene {sc.name}")
    fdt = net.cfg.frame_dt
    n = steps if steps is not None else max(1, int(round(sc.duration / fdt)))
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise DcdcError(f"steps must be >= 1 (got {steps!r})")
    system = sc.realize(dim=int(dim), resolution=resolution, frames=n + 1,
                        max_particles=max_particles)
    t = 0.0
    if settle is not None:
        frames = settle_frames(settle, fdt)
        sph = Simulator(system, sc.check_solver())  # as dcdc.evaluate.start.settle_with_sph
        for _ in range(frames):
            sph.advance(fdt)
        t = frames * fdt
        if steps is None:
            n = max(1, n - frames)
    out = rollout(net, system, n, time=t, contact=contact, device=device, progress=progress)
    out.attrs.update({"scene": sc.name, "scene_toml": sc.text, "scene_dim": sc.dim,
                      "resolution": resolution, **({"settled_by_sph_s": t} if settle else {})})
    return out
