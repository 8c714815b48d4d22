"""Non-pressure accelerations shared by both solvers: gravity, viscosity, surface tension."""
from __future__ import annotations

import numpy as np

from .interfaces import (csf_acceleration, curvature_acceleration, pairwise_acceleration,
                         pairwise_wall_images, wall_image_table)
from .kernels import lattice_second_moment
from .neighbourhood import Neighbourhood
from .reference import reference_acceleration
from .state import State
from .terms import (background_acceleration, cohesion_acceleration, mixture_density,
                    strain_rate, viscosity_acceleration, xsph_velocity_change)


def non_pressure_acceleration(s: State, nbh: Neighbourhood, no_slip: bool,
                              surface_tension: float,
                              background_pressure: float = 0.0) -> np.ndarray:
    """g + Morris viscosity (fluid-fluid; fluid-wall friction if ``no_slip``; plus the
    Smagorinsky eddy viscosity where ``s.eddy_length2`` > 0) + the walls'
    hydrostatic share (``wall_buoyancy``) + interfacial tension (``s.interface``,
    :mod:`dcdc.sph.interfaces`) + Akinci cohesion + the force of a uniform background
    pressure (:func:`dcdc.sph.terms.background_acceleration`; a constant part of the
    pressure force, applied here so that the pressure solve that follows sees it)."""
    mu = s.mu
    if s.eddy_length2 > 0:  # Smagorinsky: ν_t = (C_s 2r)² |S|
        mu = s.mu + s.rho0 * s.eddy_length2 * strain_rate(s.v, nbh.rs, nbh.idx, nbh.G, s.V0)
    mu_cross = mu if s.mu_cross is None else s.mu_cross
    a = viscosity_acceleration(s.x, s.v, s.rho0, mu, mu_cross, s.phase, no_slip, nbh.rs,
                               nbh.idx, nbh.G, s.wall_x, nbh.rsb, nbh.idxb, nbh.Gb, s.Vb, s.V0, s.h)
    a += s.gravity
    if nbh.wall_moment is not None:
        a += wall_hydrostatic_acceleration(s, nbh)
    if s.interface is not None:
        model, C = s.interface
        if model == "csf":
            a += csf_acceleration(s.phase, s.rho0, C, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0)
        elif model == "curvature":
            a += curvature_acceleration(s.x, s.phase, s.rho0, C, nbh.rs, nbh.idx, nbh.G, nbh.W,
                                        nbh.Sb, s.V0, s.h)
        else:
            a += pairwise_acceleration(s.x, s.phase, s.rho0, C, nbh.rs, nbh.idx, s.h, s.V0)
            a += pairwise_wall_images(s.x, s.phase, s.rho0, C, nbh.rs, nbh.idx, nbh.psi_wall,
                                      nbh.Sb, s.V0, s.h, *wall_image_table(s.h, s.x.shape[1], s.V0))
    if surface_tension > 0:
        a += cohesion_acceleration(s.x, s.phase, surface_tension, nbh.rs, nbh.idx, s.h)
    if background_pressure > 0:
        a += background_acceleration(background_pressure, s.rho0, nbh.rs, nbh.idx, nbh.G,
                                     nbh.Sb, s.V0)
    if s.reference is not None:
        a += reference_acceleration(s.x, s.gravity, s.rho0, *s.reference)
    return a


def wall_hydrostatic_acceleration(s: State, nbh: Neighbourhood) -> np.ndarray:
    """The walls' share of the buoyancy along them: -(ρ̄_i |g| / ρ0_i) q_t(x_i), the
    hydrostatic pressure extrapolated into the walls (Adami, Hu & Adams 2012) with the local
    mixture density ρ̄_i = Σ_j W_ij ρ0_j / Σ_j W_ij, of which only the wall-parallel part is
    applied (:meth:`dcdc.sph.volume_map.VolumeMap.tangential_moment`)."""
    rho_bar = mixture_density(s.rho0, nbh.rs, nbh.idx, nbh.W)
    g = float(np.linalg.norm(s.gravity))
    return -(rho_bar * g / s.rho0)[:, None] * nbh.wall_moment


def smooth_velocity(s: State, nbh: Neighbourhood, xsph: float) -> None:
    """Apply the momentum-conserving XSPH filter in place (no-op for ``xsph == 0``); within
    each phase only where the stabilisation stops at interfaces (``s.mu_cross`` set)."""
    if xsph > 0:
        s.v += xsph_velocity_change(s.v, s.rho0, s.phase, s.mu_cross is not None, nbh.rs,
                                    nbh.idx, nbh.W, s.V0, xsph)


def xsph_viscosity(eps: float, radius: float, support: float, dt: float, dim: int) -> float:
    """The kinematic viscosity [m²/s] that the XSPH filter amounts to for a smooth flow.

    Per substep Δv_i = ε Σ_j V0 W_ij (v_j − v_i) ≈ ε (M2 / 2d) ∇²v (Taylor expansion of v
    about x_i on the rest lattice, M2 = :func:`~dcdc.sph.kernels.lattice_second_moment`),
    i.e. per unit time ν ∇²v with ν = ε M2 / (2 d Δt): it falls only ∝ r with a CFL substep
    (docs/sph.md, "What the default stabilisation amounts to")."""
    return eps * lattice_second_moment(2.0 * radius, support * radius, dim) / (2.0 * dim * dt)
