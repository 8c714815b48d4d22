"""Multiphase SPH reference solver (DFSPH + WCSPH cross-check), its validation suite and
benchmark. Public API: :class:`SPHConfig`, :class:`Simulator` (docs/sph.md).

Threading defaults (numba workqueue layer) are set in :mod:`dcdc`."""
from .config import SPHConfig  # noqa: F401
from .solver import Simulator  # noqa: F401

__all__ = ["SPHConfig", "Simulator"]
