"""The particle system: the one data structure every stage of the pipeline passes on.

A scene (``dcdc.scene``) is realised as a :class:`ParticleSystem`; the SPH solver
(``dcdc.sph``) advances it; the dataset (``dcdc.data``) stores its frames; the model
(``dcdc.model``) predicts its next positions. Units are SI, ``y`` is up.

Fluid particles carry a phase id; each :class:`Phase` has its own rest density and
viscosity. Walls are static boundary particles with outward normals (pointing into the
fluid). Emitters are realised up front as extra fluid particles with a ``birth`` time:
a particle with ``birth > t`` is not yet part of the simulation. A particle that the solver
removes (it left the domain with ``on_escape = "remove"``) gets a finite ``death`` time
and is no longer part of it from then on: a particle is *active* at time t when
``birth <= t < death`` (:func:`active_mask`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import DcdcError, require

DEFAULT_RADIUS = 0.025  # particle radius r [m]; spacing 2r
FRAME_DT = 0.02  # [s] the interval between stored frames and one neural step (Δt)
DEFAULT_GRAVITY = (0.0, -9.81, 0.0)
RHO_REF = 1000.0  # reference density for the density embedding (paper eq. 4)
TIME_EPS = 1e-9  # [s] slack of the comparisons with birth and death times


def active_mask(birth, death, t: float) -> np.ndarray:
    """Which particles take part in the simulation at time ``t``: born (``birth <= t``) and
    not yet removed (``t < death``), each within :data:`TIME_EPS`; ``death`` None = none
    removed. A particle removed at time t_d is inactive in the frame at t_d."""
    mask = np.asarray(birth) <= t + TIME_EPS
    if death is not None:
        mask &= np.asarray(death) > t + TIME_EPS
    return mask


@dataclass(frozen=True)
class Phase:
    """One immiscible liquid: rest density ρ₀ [kg/m³], kinematic viscosity ν [m²/s]."""

    name: str
    density: float
    viscosity: float = 1e-6
    color: tuple[float, float, float] = (0.2, 0.4, 0.9)

    def __post_init__(self):
        require(np.isfinite(self.density) and self.density > 0,
                f"phases.{self.name}.density must be > 0 (got {self.density})")
        require(np.isfinite(self.viscosity) and self.viscosity >= 0,
                f"phases.{self.name}.viscosity must be >= 0 (got {self.viscosity})")


@dataclass
class ParticleSystem:
    """Fluid and wall particles of one scene at one instant.

    Attributes:
        dim: 2 or 3.
        radius: particle radius r [m]; rest spacing is 2r.
        x, v: fluid positions and velocities, float64 [N, dim].
        phase: phase index of each fluid particle, int32 [N].
        phases: the phases, indexed by ``phase``.
        wall_x, wall_n: wall particle positions and unit normals, float64 [M, dim].
        gravity: gravity vector [dim].
        domain: (lo, hi) corners of the simulation domain; a particle leaving it is an error,
            or is removed (the solver's ``on_escape``).
        birth: emission time of each fluid particle [N] (0 for particles present at t = 0).
        name: scene name, for metadata.
        death: removal time of each fluid particle [N] (inf = never removed); the SPH solver
            sets it when a particle leaves the domain with ``on_escape = "remove"``. The
            particle keeps its last position and velocity afterwards.
    """

    dim: int
    radius: float
    x: np.ndarray
    v: np.ndarray
    phase: np.ndarray
    phases: list[Phase]
    wall_x: np.ndarray
    wall_n: np.ndarray
    gravity: np.ndarray
    domain: tuple[np.ndarray, np.ndarray]
    birth: np.ndarray | None = None
    name: str = "scene"
    meta: dict = field(default_factory=dict)
    # signed distance of the walls (< 0 inside the solid), x [M, d] -> [M], when the scene
    # defines one: the SPH solver's wall volume map uses the exact solid (dcdc.sph.volume_map)
    wall_sdf: object = field(default=None, repr=False, compare=False)
    death: np.ndarray | None = None

    def __post_init__(self):
        d = self.dim
        require(d in (2, 3), f"dim must be 2 or 3 (got {d})")
        self.x = np.ascontiguousarray(self.x, dtype=np.float64).reshape(-1, d)
        n = len(self.x)
        self.v = np.ascontiguousarray(self.v, dtype=np.float64).reshape(n, d)
        self.phase = np.ascontiguousarray(self.phase, dtype=np.int32).reshape(n)
        self.wall_x = np.ascontiguousarray(self.wall_x, dtype=np.float64).reshape(-1, d)
        self.wall_n = np.ascontiguousarray(self.wall_n, dtype=np.float64).reshape(-1, d)
        self.gravity = np.asarray(self.gravity, dtype=np.float64).reshape(-1)[:d]
        lo, hi = (np.asarray(c, dtype=np.float64).reshape(d) for c in self.domain)
        self.domain = (lo, hi)
        if self.birth is None:
            self.birth = np.zeros(n)
        self.birth = np.ascontiguousarray(self.birth, dtype=np.float64).reshape(n)
        if self.death is None:
            self.death = np.full(n, np.inf)
        self.death = np.ascontiguousarray(self.death, dtype=np.float64).reshape(n)
        require(len(self.wall_n) == len(self.wall_x), "wall normals and positions differ in count")
        require(self.radius > 0, f"particle radius must be > 0 (got {self.radius})")
        if n:
            require(self.phase.min() >= 0 and self.phase.max() < len(self.phases),
                    "a fluid particle names a phase that does not exist")
        require(np.all(hi > lo), "domain.max must exceed domain.min in every axis")

    # ------------------------------------------------------------------ helpers
    @property
    def n_fluid(self) -> int:
        return len(self.x)

    @property
    def n_wall(self) -> int:
        return len(self.wall_x)

    @property
    def spacing(self) -> float:
        return 2.0 * self.radius

    @property
    def rest_density(self) -> np.ndarray:
        """Per-particle rest density ρ₀ [N]."""
        return np.array([p.density for p in self.phases], dtype=np.float64)[self.phase]

    @property
    def viscosity(self) -> np.ndarray:
        """Per-particle kinematic viscosity [N]."""
        return np.array([p.viscosity for p in self.phases], dtype=np.float64)[self.phase]

    def active(self, t: float) -> np.ndarray:
        """Boolean mask [N] of the particles active at time ``t`` (:func:`active_mask`)."""
        return active_mask(self.birth, self.death, t)

    @property
    def n_removed(self) -> int:
        """Number of particles removed so far (finite ``death``)."""
        return int(np.isfinite(self.death).sum())

    def counts_per_phase(self) -> dict[str, int]:
        counts = np.bincount(self.phase, minlength=len(self.phases))
        return {p.name: int(c) for p, c in zip(self.phases, counts)}

    def check_finite(self, t: float | None = None) -> None:
        """Raise a one-line error if any fluid position or velocity is not finite."""
        if not (np.isfinite(self.x).all() and np.isfinite(self.v).all()):
            bad = int((~np.isfinite(self.x).all(1) | ~np.isfinite(self.v).all(1)).sum())
            when = f" at t = {t:.4f} s" if t is not None else ""
            raise DcdcError(f"state turned NaN/inf{when} for {bad} particle(s)")

    def check_inside_domain(self) -> None:
        """Raise a one-line error if a fluid particle lies outside the domain (particles
        removed at t <= 0 excepted: they are never simulated)."""
        lo, hi = self.domain
        out = ~((self.x >= lo) & (self.x <= hi)).all(1) & (self.death > 0)
        if out.any():
            i = int(np.flatnonzero(out)[0])
            raise DcdcError(f"{int(out.sum())} fluid particle(s) outside the domain "
                            f"[{lo.tolist()}, {hi.tolist()}], e.g. #{i} at {self.x[i].round(4).tolist()}")

    def copy(self) -> "ParticleSystem":
        return ParticleSystem(self.dim, self.radius, self.x.copy(), self.v.copy(), self.phase.copy(),
                              list(self.phases), self.wall_x.copy(), self.wall_n.copy(),
                              self.gravity.copy(), (self.domain[0].copy(), self.domain[1].copy()),
                              self.birth.copy(), self.name, dict(self.meta), self.wall_sdf,
                              self.death.copy())
