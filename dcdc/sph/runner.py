"""A whole SPH run that keeps every frame: a realised :class:`~dcdc.particles.ParticleSystem`
advanced by the :class:`~dcdc.sph.solver.Simulator` frame by frame. :func:`dcdc.run_sph`
builds on it for a scene (load, realise, wrap the frames in a :class:`dcdc.Run`)."""
from __future__ import annotations

import numpy as np

from ..errors import DcdcError
from ..particles import FRAME_DT, ParticleSystem
from .config import SPHConfig
from .solver import Simulator


def run(system: ParticleSystem, config: SPHConfig | None = None, frames: int = 1,
        frame_dt: float = FRAME_DT, progress=None):
    """Advance ``system`` in place by the multiphase SPH solver (``config``, default
    ``SPHConfig()``) for ``frames`` frames of ``frame_dt`` seconds and return
    ``(position, velocity, time)``: float32 [frames + 1, N, d] each (frame 0 = the start) and
    the times [frames + 1] in seconds from 0. ``progress``: called with 1 after each frame
    (e.g. a tqdm bar's ``update``). A diverging run raises
    :class:`dcdc.errors.SimulationDiverged`."""
    if not (isinstance(frames, (int, np.integer)) and frames >= 0):
        raise DcdcError(f"frames must be a whole number >= 0 (got {frames!r})")
    sim = Simulator(system, config)
    xs = np.empty((frames + 1,) + system.x.shape, dtype=np.float32)
    vs = np.empty_like(xs)
    xs[0], vs[0] = system.x, system.v
    for k in range(1, frames + 1):
        sim.advance(frame_dt)
        xs[k], vs[k] = system.x, system.v
        if progress is not None:
            progress(1)
    return xs, vs, frame_dt * np.arange(frames + 1)
