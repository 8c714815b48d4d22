"""Solver settings: one typed dataclass, round-tripped through plain dicts (scene files, HDF5)."""
from __future__ import annotations

from dataclasses import MISSING, asdict, dataclass, field, fields

import math

from ..errors import DcdcError
from .interfaces import MODELS as INTERFACIAL_MODELS
from .interfaces import check_wall_tension
from .reference import AUTO_REFERENCE

SOLVERS = ("dfsph", "wcsph")
BOUNDARIES = ("map", "particles")
ON_ESCAPE = ("error", "remove")


@dataclass
class SPHConfig:
    """Settings of :class:`dcdc.sph.Simulator` (SI units), by group; docs/sph.md explains
    each group in the section named.

    Solver (docs/sph.md, "Formulation"):
        solver: "dfsph" (divergence-free + constant-density solves, Bender & Koschier 2015)
            or "wcsph" (explicit weakly compressible, Becker & Teschner 2007; a cross-check).
        support: kernel support h = support · r [particle radii].

    Time stepping ("Substeps"): Δt = min(dt_max, cfl · 2r / max(|v|_max, speed_floor)).
        cfl: Courant number: a substep moves no particle more than cfl · 2r.
        speed_floor: [m/s] the least speed the CFL condition assumes, so that substeps
            shrink with the particle size in a fluid at rest (5 ms at r = 2.5 cm).
        dt_max, dt_min: substep bounds [s]; needing less than dt_min stops the run
            (SimulationDiverged).

    Pressure solves ("Pressure solves: DFSPH with conjugate gradients", "Impacts"):
        correction_speed: u_c [m/s]: the constant-density solve removes a density error
            already present at most at the rate u_c / 2r (target max(1, ψ - Δt u_c / 2r));
            new compression is still stopped in full. 0 = unbounded (DFSPH as published),
            whose kick (ψ - 1)·2r/Δt sent particles landing on a floor past 50 m/s.
        density_tolerance: mean |ψ - 1| at which the constant-density solve stops.
        divergence_tolerance: mean compression per substep at which the divergence solve stops.
        min_iterations: relaxed Jacobi sweeps after the conjugate gradients (IISPH eq. 13).
        max_iterations: bound on the conjugate-gradient iterations of one solve.
        omega: relaxation of those Jacobi sweeps, in (0, 1].
        divergence_solve: run the divergence-free solve before the non-pressure forces.

    WCSPH ("WCSPH"): p = B max(ψ^γ - 1, 0), B = ρ0_max c² / γ.
        sound_speed: c [m/s]; 0 = 10 sqrt(2 g H) of the initial fluid height H.
        stiffness_exponent: γ of the Tait equation.

    Walls ("Walls"):
        boundary: "map" (a smooth volume map of the solid, :mod:`dcdc.sph.volume_map`: walls
            push but do not grip) or "particles" (Akinci et al. 2012 sums over the wall
            particles, whose ripple grips fluid under pressure).
        no_slip: the Morris viscosity term against the resting wall particles with each
            fluid particle's kinematic viscosity; false: free slip, no tangential force.
        wall_buoyancy: ("map" only) the hydrostatic pressure extrapolated into the walls
            along them (Adami et al. 2012, the wall-parallel part), so that light fluid by a
            side wall feels its full buoyancy; in a thin 3-D tank at rest it makes the
            walls carry part of the weight (p(H/2) = 0.85 ρgH/2).
        wall_contact_support: ("map" only) a balanced wall Φ = Ψ + A Ψ_c, Ψ_c the solid's
            integral of a kernel of this support [particle radii], so that a uniform pressure
            exerts no net force on the first row (:func:`dcdc.sph.volume_map.balanced_wall`);
            0 = the plain kernel integral Ψ.

    Damping ("Viscosity and damping", "Interface damping"):
        viscosity: artificial kinematic viscosity [m²/s] added to every phase's own.
        xsph: ε of the momentum-conserving XSPH velocity filter (damps the odd-even
            particle modes the centred divergence cannot see); 0 = off.
        interface_damping: true: ``viscosity`` and ``xsph`` act between all neighbours;
            false: between particles of the same phase only, so that unlike phases are
            coupled by their own viscosities and the pressure alone.
        smagorinsky: C_s of the eddy viscosity ν_t,i = (C_s · 2r)² |S_i|, |S| = sqrt(2 S:S)
            of the SPH strain rate (Smagorinsky 1963; in SPH Gotoh, Shibahara & Sakai 2001),
            added in the Morris term (:func:`dcdc.sph.terms.strain_rate`); 0 = off.

    Tension ("Interfacial tension", "Walls for the pairwise tension", "Wetting"):
        interfacial_tension: σ [N/m] per pair of phases (per unit depth in 2-D),
            {"oil/water": 0.05, ...} (:mod:`dcdc.sph.interfaces`); empty = none.
        interfacial_model: "curvature" (the continuum surface force σκ∇c of Brackbill et al.
            1992, curvature from a corrected SPH divergence of the normal), "pairwise"
            (a repulsion between unlike particles; separates an emulsion, weak Laplace jump)
            or "csf" (the capillary stress tensor of Lafaurie et al. 1994 in the pair form of
            Hu & Adams 2006; wants ``background_pressure``).
        wall_tension: σ_wa [N/m] per phase ("pairwise" only), {"oil": 17.3, ...}: Young's
            angle cos θ_b = (σ_wa − σ_wb) / σ_ab for a drop of b in a
            (:func:`dcdc.sph.interfaces.pairwise_wall_images`); empty = 90° for every pair.
        background_pressure: p_b [Pa] in the pressure force only, a_i = -(2 p_b/ρ0_i) ∇ψ_i
            (Hu & Adams 2006; :func:`dcdc.sph.terms.background_acceleration`), which keeps a
            tensile "csf" band from clumping; for scenes without a free surface; 0 = off.
        surface_tension: cohesion γ [m/s² per same-phase pair] of Akinci et al. 2013; 0 = off.

    Reference pressure ("Multiphase pressure: the hydrostatic reference"): the solves find
    p - q with q = ρ_ref |g| max(L - height, 0) applied as its exact gradient
    (:mod:`dcdc.sph.reference`), so light fluid does not stay under heavy fluid.
        reference_surface: L follows the fluid: one diameter below the lowest free-surface
            particle of each body of fluid ("A level that follows the surface", "A level per
            body of fluid"); with no free surface L stays at the fill height.
        reference_stratified: ρ_ref per slab one diameter thick below L from the neighbours'
            kernel mixture density ("A reference that follows the layers").
        reference_share: the share of the density the automatic reference takes out, in
            (0, 1] (default :data:`dcdc.sph.reference.AUTO_REFERENCE`); 1 together with
            ``reference_suction`` frees a thin light film under heavy fluid ("What holds the
            thin film").
        reference_suction: the constant-density solve bounds the total pressure, p' + q >= 0,
            instead of p' >= 0, more than a diameter under the level.
        reference_density: ρ_ref [kg/m³], one for every height, at most the lightest phase's
            density; it takes precedence over ``reference_stratified``. 0 = automatic:
            ``reference_share`` × the lightest phase's density when ``reference_surface`` or
            ``reference_stratified`` is on, else no reference.
        reference_level: L [m] fixed (with ``reference_surface = false``), e.g. the lid of a
            closed, filled container; None = the top of the fluid at the start (highest
            centre + r).

    Safety ("Substeps", docs/scenes.md for open scenes):
        max_speed: [m/s] a faster particle stops the run (SimulationDiverged).
        on_escape: a fluid particle leaving ``system.domain``: "error" stops the run,
            "remove" deactivates it at the end of the substep (``system.death`` = the time).
    """

    # solver
    solver: str = "dfsph"  # "dfsph" | "wcsph"
    support: float = 4.0  # h / r
    # time stepping
    cfl: float = 0.4  # substep moves <= cfl · 2r
    speed_floor: float = 4.0  # [m/s] least speed in the CFL condition
    dt_max: float = 0.005  # [s]
    dt_min: float = 1e-6  # [s] below: SimulationDiverged
    # pressure solves (DFSPH)
    correction_speed: float = 1.0  # [m/s] rate bound on removing an existing density error
    density_tolerance: float = 1e-4  # mean |ψ - 1|
    divergence_tolerance: float = 1e-3  # mean compression per substep
    min_iterations: int = 1  # Jacobi sweeps after the conjugate gradients
    max_iterations: int = 100  # conjugate-gradient iterations per solve
    omega: float = 0.5  # Jacobi relaxation
    divergence_solve: bool = True
    # WCSPH
    sound_speed: float = 0.0  # [m/s]; 0 = 10 sqrt(2 g H)
    stiffness_exponent: float = 7.0  # Tait γ
    # walls
    boundary: str = "map"  # "map" | "particles"
    no_slip: bool = False  # false: free slip
    wall_buoyancy: bool = False  # "map" only
    wall_contact_support: float = 0.0  # [r] balanced wall; "map" only
    # damping
    viscosity: float = 1e-3  # [m²/s] added to every phase's own
    xsph: float = 0.1  # XSPH filter ε
    interface_damping: bool = True  # false: viscosity and xsph within a phase only
    smagorinsky: float = 0.0  # C_s of the eddy viscosity
    # tension
    interfacial_tension: dict = field(default_factory=dict)  # {"a/b": σ [N/m]}
    interfacial_model: str = "curvature"  # "curvature" | "pairwise" | "csf"
    wall_tension: dict = field(default_factory=dict)  # {phase: σ [N/m]}, "pairwise" only
    background_pressure: float = 0.0  # [Pa] in the pressure force only
    surface_tension: float = 0.0  # [m/s²] Akinci cohesion
    # reference pressure
    reference_surface: bool = True  # L follows each body's free surface
    reference_stratified: bool = True  # ρ_ref per slab below L
    reference_share: float = AUTO_REFERENCE  # share of the density taken out
    reference_suction: bool = True  # solves bound p' + q >= 0 under the level
    reference_density: float = 0.0  # [kg/m³] one ρ_ref; 0 = automatic
    reference_level: float | None = None  # [m] fixed L; None = the fill height
    # safety
    max_speed: float = 50.0  # [m/s] faster: SimulationDiverged
    on_escape: str = "error"  # "error" | "remove"

    def __post_init__(self):
        self.validate()

    def validate(self) -> "SPHConfig":
        for name, choices in (("solver", SOLVERS), ("boundary", BOUNDARIES),
                              ("on_escape", ON_ESCAPE), ("interfacial_model", INTERFACIAL_MODELS)):
            if getattr(self, name) not in choices:
                raise DcdcError(f"sph.{name} must be one of {', '.join(choices)} "
                                f"(got {getattr(self, name)!r})")
        positive = ("support", "cfl", "speed_floor", "dt_max", "dt_min", "density_tolerance",
                    "divergence_tolerance", "omega", "stiffness_exponent", "max_speed")
        for name in positive:
            _check_number(self, name, lambda v: v > 0, "> 0")
        for name in ("viscosity", "xsph", "surface_tension", "sound_speed", "correction_speed",
                     "background_pressure", "wall_contact_support", "smagorinsky",
                     "reference_density"):
            _check_number(self, name, lambda v: v >= 0, ">= 0")
        for name in ("min_iterations", "max_iterations"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise DcdcError(f"sph.{name} must be an integer >= 1 (got {v!r})")
        for name in ("divergence_solve", "no_slip", "wall_buoyancy", "reference_surface",
                     "reference_stratified", "reference_suction"):
            if not isinstance(getattr(self, name), bool):
                raise DcdcError(f"sph.{name} must be true or false (got {getattr(self, name)!r})")
        if self.support <= 2.0:
            raise DcdcError(f"sph.support must exceed 2 particle radii (got {self.support})")
        if self.cfl > 1.0:
            raise DcdcError(f"sph.cfl must be <= 1 (got {self.cfl})")
        if self.reference_level is not None:
            _check_number(self, "reference_level", lambda v: True, "[m]")
            if self.reference_surface is True:
                raise DcdcError("sph.reference_level fixes the reference level, which "
                                "sph.reference_surface (on by default) moves: set "
                                "sph.reference_surface = false with it")
        _check_number(self, "reference_share", lambda v: 0 < v <= 1, "in (0, 1]")
        if self.omega > 1.0:
            raise DcdcError(f"sph.omega must be <= 1 (got {self.omega})")
        if self.dt_min > self.dt_max:
            raise DcdcError(f"sph.dt_min ({self.dt_min}) exceeds sph.dt_max ({self.dt_max})")
        if self.min_iterations > self.max_iterations:
            raise DcdcError("sph.min_iterations exceeds sph.max_iterations")
        for name, what in (("interfacial_tension", "\"a/b\" = σ [N/m]"),
                           ("wall_tension", "phase = σ [N/m]")):
            table = getattr(self, name)
            if not isinstance(table, dict):
                raise DcdcError(f"sph.{name} must be a table of {what}")
            for k, v in table.items():
                if isinstance(v, bool) or not isinstance(v, (int, float)) \
                        or not math.isfinite(v) or v < 0:
                    raise DcdcError(f"sph.{name}.{k} must be a finite number >= 0 (got {v!r})")
        check_wall_tension(self.interfacial_model, self.interfacial_tension, self.wall_tension)
        return self

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict | None) -> "SPHConfig":
        if d is None:
            return cls()
        if not isinstance(d, dict):
            raise DcdcError(f"sph settings must be a table/dict (got {type(d).__name__})")
        known = {f.name: f for f in fields(cls)}
        unknown = sorted(set(d) - set(known))
        if unknown:
            raise DcdcError(f"unknown sph setting {unknown[0]!r} (known: {', '.join(known)})")
        kw = {}
        for k, v in d.items():
            f = known[k]
            default = f.default if f.default is not MISSING else f.default_factory()
            if default is None:  # an optional number (reference_level): None or a float
                if v is None:
                    kw[k] = v
                    continue
                default = 0.0
            if isinstance(default, float) and isinstance(v, int) and not isinstance(v, bool):
                v = float(v)
            if type(v) is not type(default):
                raise DcdcError(f"sph.{k} must be a {type(default).__name__} (got {v!r})")
            kw[k] = v
        return cls(**kw)


def _check_number(cfg, name, ok, what):
    v = getattr(cfg, name)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != v or not ok(v) \
            or v == float("inf"):
        raise DcdcError(f"sph.{name} must be a finite number {what} (got {v!r})")
