"""Explicit weakly compressible SPH (Becker & Teschner 2007, "Weakly compressible SPH for
free surface flows") on the same number-density, volume-symmetric operators as DFSPH: the
cross-check solver.

Tait equation with one stiffness B for all phases (so the pressure field is continuous
across an interface), clamped at 0 to avoid tensile instability at the free surface:
    p_i = B max((ψ_i)^γ - 1, 0),   B = ρ0_max c² / γ.
The light phase then has the fastest sound speed c_max = c·sqrt(ρ0_max / ρ0_min), which
bounds the substep: Δt <= cfl · 2r / (c_max + |v|_max). Symplectic Euler integration.
"""
from __future__ import annotations

import numpy as np

from .config import SPHConfig
from .forces import non_pressure_acceleration, smooth_velocity
from .neighbourhood import Neighbourhood
from .state import State
from .terms import pressure_acceleration


def stiffness(rho0: np.ndarray, c: float, gamma: float) -> float:
    return float(rho0.max()) * c * c / gamma


def max_sound_speed(rho0: np.ndarray, c: float) -> float:
    return c * float(np.sqrt(rho0.max() / rho0.min()))


def substep(s: State, nbh: Neighbourhood, dt: float, cfg: SPHConfig, c: float) -> dict:
    gamma = cfg.stiffness_exponent
    B = stiffness(s.rho0, c, gamma)
    s.p[:] = B * np.maximum(nbh.psi ** gamma - 1.0, 0.0)
    a = non_pressure_acceleration(s, nbh, cfg.no_slip, cfg.surface_tension,
                                  cfg.background_pressure)
    ap = np.empty_like(a)
    pressure_acceleration(s.p, s.rho0, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0, ap)
    s.v += dt * (a + ap)
    smooth_velocity(s, nbh, cfg.xsph)
    s.x += dt * s.v
    return {"iterations": 0, "divergence_iterations": 0, "solver_error": 0.0,
            "divergence_error": 0.0}
