"""Multiphase SPH reference solver (DFSPH + WCSPH cross-check), its validation suite and
benchmark. Public API: :class:`SPHConfig`, :class:`Simulator` (docs/sph.md) and
:func:`run`, a whole scene simulated into a :class:`dcdc.api.Run` (docs/api.md).

Threading defaults (numba workqueue layer) are set in :mod:`dcdc`."""
from .config import SPHConfig  # noqa: F401
from .solver import Simulator  # noqa: F401

__all__ = ["SPHConfig", "Simulator", "run"]


def run(scene, dim=None, resolution=1.0, duration=None, solver=None, max_particles=None,
        progress=False):
    """Simulate ``scene`` (a built-in name, a .toml path, TOML text or a Scene) with this
    solver: :func:`dcdc.api.run_sph` (the same as ``dcdc.run_sph``)."""
    from ..api import run_sph
    return run_sph(scene, dim=dim, resolution=resolution, duration=duration, solver=solver,
                   max_particles=max_particles, progress=progress)
