"""The arrays one substep works on: the active fluid particles and the static walls."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class State:
    x: np.ndarray  # [n, d] positions (updated in place)
    v: np.ndarray  # [n, d] velocities (updated in place)
    phase: np.ndarray  # [n] int32
    rho0: np.ndarray  # [n] rest density
    mu: np.ndarray  # [n] dynamic viscosity ρ0 (ν_phase + ν_artificial)
    p: np.ndarray  # [n] pressure of the constant-density solve (warm start), or WCSPH pressure
    p_div: np.ndarray  # [n] pressure of the divergence-free solve (warm start)
    wall_x: np.ndarray  # [m, d]
    Vb: np.ndarray  # [m] Akinci volumes
    gravity: np.ndarray  # [d]
    V0: float  # rest volume of a fluid particle (2r)^d
    h: float  # kernel support
    # interfacial tension: (model, [phases, phases] coefficients of dcdc.sph.interfaces) or None
    interface: tuple[str, np.ndarray] | None = None
    # (C_s · 2r)² of the Smagorinsky eddy viscosity (SPHConfig.smagorinsky); 0 = off
    eddy_length2: float = 0.0
    # SPHConfig.interface_damping off: the dynamic viscosity of unlike pairs (ρ0 ν_phase, no
    # artificial part), and XSPH within each phase only; None = the stabilisation acts on all
    mu_cross: np.ndarray | None = None
    # the hydrostatic reference pressure (dcdc.sph.reference): (ρ_ref, L, slab thickness),
    # ρ_ref a number (thickness 0) or one per slab under L (reference_stratified); None = off
    reference: tuple | None = None

    @property
    def dim(self) -> int:
        return self.x.shape[1]
