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
    """Settings of :class:`dcdc.sph.Simulator` (SI units).

    solver: "dfsph" (implicit: divergence-free + constant-density solves, Bender & Koschier
        2015) or "wcsph" (explicit weakly compressible, Becker & Teschner 2007; cross-check).
    support: kernel support h in particle radii (h = support · r; default 4).
    cfl: Courant number; a substep moves no particle more than cfl · 2r.
    correction_speed: the constant-density solve removes a density error already present at
        most at the rate u_c / 2r per second [m/s] (new compression is still stopped in
        full); without the bound it removes all of it in one substep, with a velocity
        (ψ - 1)·2r/Δt that grows as Δt shrinks: after a block landed on a floor, that kick
        sent particles past 50 m/s (171 of 1 000 random 2-D scenes, docs/sph.md,
        "Impacts"). At rest the error is ~1e-3, far below u_c·Δt/2r = 0.1 (5 ms substeps,
        r = 2.5 cm), so the bound is idle there. 0 = unbounded (DFSPH as published).
    speed_floor: the CFL condition uses max(|v|_max, speed_floor) [m/s], so substeps shrink
        with the particle size even in a fluid at rest (Δt <= cfl·2r/speed_floor: 5 ms at
        r = 2.5 cm, 2.5 ms at 1.25 cm); a heavy layer over a light one at r = 1.25 cm
        exploded with 5 ms substeps and ran stably with 2.5 ms.
    dt_max, dt_min: substep bounds [s]; needing less than dt_min means divergence.
    density_tolerance: mean |ψ - 1| residual per substep at which the density solve stops.
    divergence_tolerance: mean compression per substep at which the divergence solve stops.
    min_iterations, max_iterations: pressure-solver iteration bounds per solve.
    omega: Jacobi relaxation of the pressure solves.
    divergence_solve: run DFSPH's divergence-free solve.
    viscosity: artificial kinematic viscosity added to every phase's own [m²/s].
    smagorinsky: Smagorinsky constant C_s of a sub-particle-scale eddy viscosity
        ν_t,i = (C_s · 2r)² |S_i| (Smagorinsky 1963; in SPH: Gotoh, Shibahara & Sakai 2001,
        Dalrymple & Rogers 2006), added to each particle's kinematic viscosity in the Morris
        term (:func:`dcdc.sph.terms.strain_rate`); |S| = sqrt(2 S:S), S the SPH strain rate.
        It removes the energy that reaches the particle scale and vanishes as (2r)² under
        refinement; 0 = off.
    xsph: strength ε of the momentum-conserving XSPH velocity filter (damps the odd-even
        particle modes that SPH's centred divergence cannot see; 0 = off).
    interface_damping: true: ``viscosity`` and ``xsph`` act between all neighbours; false:
        only between particles of the same phase, so that unlike phases are coupled by
        their own (physical) viscosities and the pressure alone (docs/sph.md, "Interface
        damping").
    no_slip: walls with friction: the Morris viscosity term against the (resting) wall
        particles with each fluid particle's own kinematic viscosity (phase + ``viscosity``);
        false (default): free slip, the walls push but exert no tangential force.
    wall_buoyancy: (volume map only) extrapolate the hydrostatic pressure into the walls
        along them (Adami et al. 2012, wall-parallel part only), so that light fluid along a
        side wall feels its full buoyancy; off by default: in a thin 3-D tank at rest it
        makes the walls carry part of the weight (p(H/2) = 0.85 ρgH/2, docs/sph.md).
    wall_contact_support: (volume map only) a *balanced* wall: Φ = Ψ + A Ψ_c with Ψ_c the
        solid's integral of a kernel of this support [particle radii], so that a uniform
        pressure exerts no net force on the first row of the rest lattice
        (:func:`dcdc.sph.volume_map.balanced_wall`); 0 = the plain kernel integral Ψ.
    boundary: how the walls enter density and pressure: "map" (a smooth volume map of the
        solid, :mod:`dcdc.sph.volume_map`: walls push but do not grip) or "particles"
        (Akinci et al. 2012 sums over the wall particles; their ripple grips fluid under
        pressure, docs/sph.md).
    surface_tension: Akinci et al. 2013 cohesion γ [m/s² per same-phase pair] (0 = off).
    interfacial_tension: σ [N/m] per pair of phases (per unit depth in 2-D),
        {"oil/water": 0.05, ...} (:mod:`dcdc.sph.interfaces`); empty = none.
    wall_tension: σ_wa [N/m] per phase ("pairwise" only), {"oil": 17.3, ...}: the walls'
        tension against each phase (unnamed phases 0; only differences matter), which sets
        the contact angle by Young's law, cos θ_b = (σ_wa − σ_wb) / σ_ab for a drop of b in
        a (:func:`dcdc.sph.interfaces.pairwise_wall_images`; reached by a receding contact
        line in 2-D, with a large hysteresis, docs/sph.md "Wetting"); empty = 90° for every pair.
    interfacial_model: "curvature" (default: the continuum surface force σκ∇c of Brackbill
        et al. 1992 with the curvature from a corrected SPH divergence of the interface
        normal; Laplace jump 0.92-0.93 σ/R on the validation drops), "pairwise" (a
        repulsion between unlike particles, pairwise-force SPH; separates an emulsion, but
        its Laplace jump is 0.13-0.26 σ/R; the cocktail's, pinned in its scene file) or
        "csf" (the capillary stress tensor of Lafaurie et al. 1994 in the SPH pair form of
        Hu & Adams 2006; exact force on a lattice drop, but without a background pressure
        its interface band is under tension and clumps: jump 0.46-0.69 of Young-Laplace;
        with ``background_pressure`` = σ/h 0.79-0.83; docs/sph.md).
    background_pressure: p_b [Pa] added to the pressure in the pressure force only (Hu &
        Adams 2006; Adami, Hu & Adams 2010): a_i = -(2 p_b/ρ0_i) ∇ψ_i, the walls carrying
        p_b too (:func:`dcdc.sph.terms.background_acceleration`). It changes neither the
        pressure solve nor :meth:`Simulator.pressure`; it keeps a band whose capillary
        stress is tensile ("csf") from clumping. Only for scenes without a free surface
        (there ∇ψ points inward and p_b would blow the surface apart). 0 = off (default).
    reference_density: ρ_ref [kg/m³] of a hydrostatic reference pressure
        q = ρ_ref |g| max(L - height, 0) that is applied as its exact gradient (a uniform
        body force against gravity below L) instead of through the pair-sum pressure force;
        the solves then find p - q (:mod:`dcdc.sph.reference`). A gauge in the continuum;
        discretely the particle arrangement's stiffness then follows p - q, not the depth,
        so light fluid does not stay under heavy fluid and thin layers deep under heavier
        fluid can move. Exact in a container without a free surface; with one, only while
        that surface stays at L. At most the lightest phase's density. 0 (default) =
        ``reference_share`` × the lightest phase's density with ``reference_surface`` or per
        height with ``reference_stratified`` (the defaults), off without both.
    reference_share: the share of the density that the automatic reference takes out
        (default :data:`dcdc.sph.reference.AUTO_REFERENCE` = 1, in (0, 1]): below 1 the
        fluid keeps that part of its weight in the pair force, which closes gaps under the
        level as long as the solves only push (0.9 suits a solver without suction); 1
        together with ``reference_suction`` frees the thin film of light fluid under heavy
        fluid (docs/sph.md, "What holds the thin film").
    reference_suction: the constant-density solve bounds the total pressure, p' + q >= 0,
        instead of p' >= 0, for its particles (a full neighbourhood, not expanded) more than
        a diameter under the level: a liquid under a head can be below its hydrostatic
        pressure, so a gap under the level rises as a bubble does. On by default
        (docs/sph.md, "What holds the thin film").
    reference_level: L [m], the height (along -g) where q = 0, fixed (only with
        ``reference_surface = false``): for a closed, completely filled container any height
        at or above the fluid (e.g. its lid). Unset (None, the default) = the top of the
        fluid at the start, the highest particle centre + r (a scene's fill height at any
        resolution).
    reference_surface: L follows the fluid (default on): at every substep
        it is one particle diameter below the lowest free-surface particle (a one-sided
        neighbourhood, walls included) of each body of fluid, a connected component of the
        neighbour graph (:func:`dcdc.sph.reference.surface_levels`; one level per body),
        so the reference holds wherever the fluid is covered up to L, in
        open scenes too: the surface's troughs, splashes and droplets still attached to the
        bulk lower L instead of floating, and fluid spilled apart from it has a level of its
        own. With no free surface (a closed, filled body) L stays at the fill height. No
        effect without gravity. ``false`` together with ``reference_stratified = false`` and
        ``reference_density`` 0 is the solver without any reference (docs/sph.md, "A level
        that follows the surface").
    reference_stratified: ρ_ref varies with height (default on): at every
        substep, 0.9 × the lowest kernel mixture density of the neighbours,
        ρ̄ = Σ W ρ0 / Σ W (not the lightest phase present: a lone particle does not set it), in each
        slab one particle diameter thick below L (:func:`dcdc.sph.reference.strata`), so
        under a layer of heavy fluid the reference takes out that layer's level, not just the
        lightest phase's share of it (docs/sph.md, "A reference that follows the layers").
        An explicit ``reference_density`` is one ρ_ref for every height and takes precedence
        (a saved configuration holds both switches, so both together are not an error).
    sound_speed: WCSPH speed of sound [m/s] (0 = 10·sqrt(2 g H) of the initial fluid height).
    stiffness_exponent: WCSPH Tait exponent.
    max_speed: a speed above this [m/s] counts as an explosion (SimulationDiverged).
    on_escape: what a fluid particle leaving ``system.domain`` does: "error" (default: the
        run stops with SimulationDiverged) or "remove" (it is deactivated at the end of
        that substep: no longer stepped, no longer a neighbour, its ``system.death`` set to
        the time; for open scenes whose fluid falls away, docs/sph.md).
    """

    solver: str = "dfsph"
    support: float = 4.0
    cfl: float = 0.4
    correction_speed: float = 1.0
    speed_floor: float = 4.0
    dt_max: float = 0.005
    dt_min: float = 1e-6
    density_tolerance: float = 1e-4
    divergence_tolerance: float = 1e-3
    min_iterations: int = 1
    max_iterations: int = 100
    omega: float = 0.5
    divergence_solve: bool = True
    viscosity: float = 1e-3
    smagorinsky: float = 0.0
    xsph: float = 0.1
    interface_damping: bool = True
    no_slip: bool = False
    boundary: str = "map"
    wall_buoyancy: bool = False
    wall_contact_support: float = 0.0
    surface_tension: float = 0.0
    interfacial_tension: dict = field(default_factory=dict)
    wall_tension: dict = field(default_factory=dict)
    interfacial_model: str = "curvature"
    background_pressure: float = 0.0
    reference_suction: bool = True
    reference_share: float = AUTO_REFERENCE
    reference_density: float = 0.0
    reference_level: float | None = None
    reference_surface: bool = True
    reference_stratified: bool = True
    sound_speed: float = 0.0
    stiffness_exponent: float = 7.0
    max_speed: float = 50.0
    on_escape: str = "error"

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
