"""Non-pressure accelerations shared by both solvers: gravity, viscosity, surface tension."""
from __future__ import annotations

import numpy as np

from .neighbourhood import Neighbourhood
from .state import State
from .terms import cohesion_acceleration, viscosity_acceleration, xsph_velocity_change


def non_pressure_acceleration(s: State, nbh: Neighbourhood, wall_viscosity: float,
                              surface_tension: float) -> np.ndarray:
    """g + Morris viscosity (fluid-fluid, fluid-wall friction) + Akinci cohesion."""
    a = viscosity_acceleration(s.x, s.v, s.rho0, s.mu, wall_viscosity, nbh.rs, nbh.idx, nbh.G,
                               s.wall_x, nbh.rsb, nbh.idxb, nbh.Gb, s.Vb, s.V0, s.h)
    a += s.gravity
    if surface_tension > 0:
        a += cohesion_acceleration(s.x, s.phase, surface_tension, nbh.rs, nbh.idx, s.h)
    return a


def smooth_velocity(s: State, nbh: Neighbourhood, xsph: float) -> None:
    """Apply the momentum-conserving XSPH filter in place (no-op for ``xsph == 0``)."""
    if xsph > 0:
        s.v += xsph_velocity_change(s.v, s.rho0, nbh.rs, nbh.idx, nbh.W, s.V0, xsph)
