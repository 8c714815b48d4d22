"""Multiphase SPH reference solver (DFSPH + WCSPH cross-check), its validation suite and
benchmark. Public API: :class:`SPHConfig`, :class:`Simulator` (docs/sph.md) and :func:`run`,
a realised ParticleSystem advanced frame by frame with every frame kept (a whole scene into
a :class:`dcdc.Run`: :func:`dcdc.run_sph`, docs/api.md).

Threading defaults (numba workqueue layer) are set in :mod:`dcdc`."""
from .config import SPHConfig  # noqa: F401
from .runner import run  # noqa: F401
from .solver import Simulator  # noqa: F401

__all__ = ["SPHConfig", "Simulator", "run"]
