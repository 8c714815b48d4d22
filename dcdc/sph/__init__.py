"""Multiphase SPH reference solver (DFSPH + WCSPH cross-check), its validation suite and
benchmark. Public API: :class:`SPHConfig`, :class:`Simulator` (docs/sph.md)."""
import os as _os

import numba as _numba

# numba's default OpenMP layer spin-waits at every parallel region; on this 2-core machine,
# shared with other jobs, that made one neighbour pass 8x slower with 2 threads than with 1
# (11.6 ms vs 1.6 ms at 10 k particles); the workqueue layer took 1.0 ms. Set before the
# first parallel launch of the process; an explicit NUMBA_THREADING_LAYER wins.
if "NUMBA_THREADING_LAYER" not in _os.environ:
    _numba.config.THREADING_LAYER = "workqueue"

from .config import SPHConfig  # noqa: E402,F401
from .solver import Simulator  # noqa: E402,F401

__all__ = ["SPHConfig", "Simulator"]
