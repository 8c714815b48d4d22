"""The hydrostatic reference pressure (SPHConfig.reference_density, dcdc.sph.reference)."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.particles import Phase
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.fixtures import tank_system
from dcdc.sph.measures import EnergyBudget, run
from dcdc.sph.reference import AUTO_REFERENCE as SHARE
from dcdc.sph.reference import reference_acceleration, reference_pressure


def test_force_is_the_exact_gradient_of_q():
    """-∇q/ρ0 by central differences of q, below the level; nothing above it."""
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, (50, 3))
    g = np.array([0.3, -9.0, 1.0])
    rho0 = rng.uniform(500, 3000, 50)
    a = reference_acceleration(x, g, rho0, 700.0, 0.6)
    eps = 1e-6
    for k in range(3):
        dx = np.zeros(3)
        dx[k] = eps
        dq = (reference_pressure(x + dx, g, 700.0, 0.6) - reference_pressure(x - dx, g, 700.0, 0.6))
        np.testing.assert_allclose(a[:, k], -dq / (2 * eps) / rho0, rtol=1e-6, atol=1e-9)
    up = -g / np.linalg.norm(g)
    assert np.all(a[x @ up > 0.6] == 0) and np.all(a[x @ up < 0.6] @ up > 0)


def test_the_layered_reference_is_the_exact_gradient_of_its_q():
    """reference_stratified: q of a slab profile is continuous, its force is -∇q/ρ0 (central
    differences away from the slab faces), the profile is the share (AUTO_REFERENCE) × the
    lowest density given in each slab, and below the deepest slab it continues the
    deepest's density."""
    from dcdc.sph.reference import strata
    rng = np.random.default_rng(1)
    g = np.array([0.0, -9.81])
    level, dz = 1.0, 0.05
    # two layers: light (500) above 0.6 m, heavy (2000) below; one light particle at 0.3 m
    y = np.concatenate([rng.uniform(0.6, 1.0, 200), rng.uniform(0.0, 0.6, 300), [0.32]])
    rho0 = np.concatenate([np.full(200, 500.0), np.full(300, 2000.0), [500.0]])
    x = np.c_[rng.uniform(0, 1, len(y)), y]
    prof = strata(x, rho0, g, level, dz)
    depth_mid = level - (np.arange(len(prof)) + 0.5) * dz
    assert np.all(prof[depth_mid > 0.6] == SHARE * 500.0)
    assert np.all(prof[(depth_mid < 0.55) & (np.abs(depth_mid - 0.325) > 0.03)] == SHARE * 2000.0)
    assert prof[int((level - 0.32) / dz)] == SHARE * 500.0
    xs = np.c_[rng.uniform(0, 1, 400), rng.uniform(-0.2, 1.2, 400)]
    rho_i = rng.uniform(500, 3000, 400)
    off_face = np.abs(((level - xs[:, 1]) / dz) - np.round((level - xs[:, 1]) / dz)) > 1e-3
    a = reference_acceleration(xs, g, rho_i, prof, level, dz)
    eps = 1e-6
    dq = (reference_pressure(xs + [0, eps], g, prof, level, dz)
          - reference_pressure(xs - [0, eps], g, prof, level, dz)) / (2 * eps)
    np.testing.assert_allclose(a[off_face, 1], -dq[off_face] / rho_i[off_face], rtol=1e-6)
    faces = np.c_[np.zeros(len(prof)), level - np.arange(len(prof)) * dz]
    np.testing.assert_allclose(reference_pressure(faces + [0, 1e-9], g, prof, level, dz),
                               reference_pressure(faces - [0, 1e-9], g, prof, level, dz), atol=1e-3)
    deep = np.array([[0.5, -0.5]])
    assert reference_acceleration(deep, g, np.array([1000.0]), prof, level, dz)[0, 1] == \
        pytest.approx(prof[-1] * 9.81 / 1000.0)


def test_a_lone_light_particle_does_not_set_its_slabs_reference():
    """The solver gives strata the neighbours' kernel mixture densities: a light particle
    alone in a heavy lattice (at the pressure of the heavy fluid around it) leaves its slab's
    reference far above its own density, while a light layer a kernel thick sets its slab to
    the share × its density (the oil held at the 3-D cocktail's glass lowered its slabs'
    reference before)."""
    from dcdc.neighbors import radius_search
    from dcdc.sph.reference import strata
    from dcdc.sph.terms import edge_kernels, mixture_density
    d, h = 0.02, 0.04
    x = np.stack(np.meshgrid(d * np.arange(30), d * np.arange(30)), -1).reshape(-1, 2)
    rho0 = np.where(x[:, 1] > 0.45, 500.0, 2000.0)  # light layer on top: rows 23-29
    lone = np.flatnonzero(np.isclose(x[:, 0], 0.3) & np.isclose(x[:, 1], 0.2))
    rho0[lone] = 500.0
    nb = radius_search(x, h)
    W, _ = edge_kernels(x, x, nb.row_splits, nb.index, h)
    rho_bar = mixture_density(rho0, nb.row_splits, nb.index, W, exclude_self=True)  # as the solver
    level, dz = 0.61, d  # rows at the slabs' middles
    g = np.array([0.0, -9.81])
    prof = strata(x, rho_bar, g, level, dz)
    assert prof[int((level - 0.2) / dz)] > 0.9 * 1200.0
    assert prof[int((level - 0.52) / dz)] == pytest.approx(SHARE * 500.0)
    # by ρ0: its own density
    assert strata(x, rho0, g, level, dz)[int((level - 0.2) / dz)] == SHARE * 500.0


def _closed_tank(r, phase_of, phases):
    W, H = 0.4, 0.3
    return tank_system(2, r, (W, H), [((0, 0), (W, H), phase_of)], phases, wall_height=H,
                       closed=True)


def test_reference_above_the_lightest_phase_is_an_error():
    sy = _closed_tank(0.02, lambda p: np.zeros(len(p), int), [Phase("w", 1000.0)])
    with pytest.raises(DcdcError, match="lightest"):
        Simulator(sy, SPHConfig(reference_density=1200.0, reference_surface=False))


@pytest.mark.slow
def test_a_closed_filled_tank_at_rest_is_unchanged():
    """In a container without a free surface q is a gauge: the reported pressure p' + q has
    the hydrostatic slope. With suction (the default) the solves' bound is the physical one,
    total pressure >= 0, as without a reference, so the fluid moves as without one; with the
    solves held at p' >= 0 instead they only see p - q ~ 0 and the fluid stays still."""
    out = {}
    for rho_ref, suction in ((0.0, True), (1000.0, True), (1000.0, False)):
        sy = _closed_tank(0.0125, lambda p: np.zeros(len(p), int), [Phase("w", 1000.0)])
        sim = Simulator(sy, SPHConfig(reference_density=rho_ref, reference_level=0.3,
                                      reference_surface=False, reference_suction=suction))
        sim.run(1.0)
        y, p = sy.x[:, 1], sim.pressure()
        inner = (y > 0.1) & (y < 0.2) & (sy.x[:, 0] > 0.1) & (sy.x[:, 0] < 0.3)
        slope = np.polyfit(y[inner], p[inner], 1)[0]
        out[rho_ref, suction] = (slope / (-1000.0 * 9.81), float(np.abs(sy.v).max()))
    # measured: without a reference slope 1.03, 0.014 m/s (the lattice start settling; the
    # lid's row sits under the pair sum's level term); with it and suction 1.001, 0.019 m/s;
    # with it and p' >= 0 1.0000, 1.4e-5 m/s
    slope, vmax = out[1000.0, False]
    assert abs(slope - 1.0) < 0.02 and vmax < 0.005, out
    slope, vmax = out[1000.0, True]
    assert abs(slope - 1.0) < 0.02 and vmax < 0.05, out
    slope, vmax = out[0.0, True]
    assert abs(slope - 1.0) < 0.1 and vmax < 0.1, out


@pytest.mark.slow
def test_energy_budget_holds_with_the_reference():
    """Heavy over light in a closed filled box with the reference: the body force is an
    external potential whose energy is constant when the box stays filled, so the kinetic
    energy never exceeds the gravitational energy released."""
    sy = _closed_tank(0.01, lambda p: np.where(p[:, 1] > 0.15 + 0.03 * np.cos(2 * np.pi * p[:, 0] / 0.4),
                                             0, 1), [Phase("heavy", 2000.0), Phase("light", 1000.0)])
    sim = Simulator(sy, SPHConfig(reference_density=1000.0, reference_level=0.3,
                                  reference_surface=False))
    energy = EnergyBudget(sim)
    run(sim, 1.5, energy)
    row = energy.row("rt")
    assert row.passed, row
    assert sy.x[sy.phase == 0, 1].mean() < sy.x[sy.phase == 1, 1].mean() + 0.05  # it moved


def test_the_level_defaults_to_the_fill_height():
    """reference_level unset: the top of the fluid at the start (highest centre + r), here
    0.2 m in a 0.3 m tall closed tank filled to 0.2 m; an explicit level is used as given."""
    W, H, r = 0.4, 0.3, 0.02
    sy = tank_system(2, r, (W, 0.2), [((0, 0), (W, 0.2), lambda p: np.zeros(len(p), int))],
                     [Phase("w", 1000.0)], wall_height=H, closed=True)
    top = sy.x[:, 1].max() + r
    assert abs(top - 0.2) < 1e-9
    assert Simulator(sy, SPHConfig(reference_density=800.0))._reference == (800.0, top, 0.0)
    assert Simulator(sy, SPHConfig(reference_density=800.0, reference_level=0.5,
                                   reference_surface=False))._reference[1] == 0.5


def test_reference_level_settings():
    """None (unset) and numbers are accepted and survive a round trip; anything else is a
    one-line error."""
    assert SPHConfig.from_dict({}).reference_level is None
    assert SPHConfig.from_dict({"reference_level": 1, "reference_surface": False}).reference_level == 1.0
    c = SPHConfig(reference_density=500.0)
    assert SPHConfig.from_dict(c.to_dict()) == c
    for bad in ("top", float("nan"), True):
        with pytest.raises(DcdcError, match="reference_level"):
            SPHConfig.from_dict({"reference_level": bad, "reference_surface": False})


def test_the_built_in_closed_scenes_carry_the_closed_settings():
    """lock_exchange and hourglass are filled up to their lids: they run with the
    closed-container damping that the validation's lock-exchange rows check
    (dcdc.sph.reference.closed_container) and a reference of their light phase's density
    (the box, filled with whole rows) or 0.9 of it (the hourglass, whose lattice leaves gaps
    at the shoulders that must be able to rise).
    The hourglass also has interfacial tension between its liquids (with it the
    drain converges under refinement, docs/sph.md "Why tension makes it converge")."""
    import dataclasses

    from dcdc.scene import get_scene
    from dcdc.sph.reference import closed_container
    for name, share in (("lock_exchange", 1.0), ("hourglass", 0.9)):
        scene = get_scene(name)
        light = min(p["density"] for p in scene.data["phases"].values())
        got = dataclasses.replace(scene.check_solver(), interfacial_tension={})
        assert got == SPHConfig.from_dict(closed_container({}, share * light)), name
    assert not get_scene("lock_exchange").check_solver().interfacial_tension
    sigma = get_scene("hourglass").check_solver().interfacial_tension
    assert list(sigma) == ["light/heavy"] and sigma["light/heavy"] > 0


def test_closed_container_settings_override_the_reference_options():
    """The lock-exchange case runs closed_container(cfg) whatever the given cfg: with
    reference_stratified or reference_surface given, the result is still valid settings."""
    from dcdc.sph.reference import closed_container
    for given in (SPHConfig(reference_stratified=True), SPHConfig(reference_surface=True)):
        c = SPHConfig.from_dict(closed_container(given.to_dict(), 1000.0))
        assert (c.reference_density, c.reference_surface, c.reference_stratified) == (1000.0, False, False)


def test_surface_levels_find_the_lowest_free_surface_particle():
    """An open tank on the rest lattice: its free surface is the top row (every particle's
    level is the top row's height), the particles at the floor and side walls are not at a
    surface; the same tank closed and filled up to its lid has no free surface (the fill
    level given)."""
    from dcdc.sph.neighbourhood import build
    from dcdc.sph.reference import surface_levels
    from dcdc.sph.terms import psi_gradient
    W, H, r = 0.4, 0.2, 0.01
    for closed, expect in ((False, H - r), (True, 7.0)):  # the top row's centre; the fill
        sy = tank_system(2, r, (W, H), [((0, 0), (W, H), lambda p: np.zeros(len(p), int))],
                         [Phase("w", 1000.0)], wall_height=H, closed=closed)
        sim = Simulator(sy, SPHConfig())
        s = sim._state(None)
        nbh = build(s.x, sim._walls, sim.Vb, sim.h, sim.V0, sim.volume_map, sim._wall_edges)
        level = surface_levels(s.x, psi_gradient(nbh.rs, nbh.G, nbh.Sb, sim.V0), sim.h,
                               s.gravity, nbh.rs, nbh.idx, fill=7.0)
        np.testing.assert_allclose(level, expect, atol=1e-9)


def test_bodies_are_the_connected_components_of_the_neighbour_graph():
    """dcdc.sph.reference.bodies partitions random points as scipy's connected_components
    does (hundreds of components, and one)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components
    from dcdc.neighbors import radius_search
    from dcdc.sph.reference import bodies
    x = np.random.default_rng(0).uniform(0, 1, (3000, 3))
    for radius in (0.06, 0.2):
        nb = radius_search(x, radius)
        count, body = bodies(nb.row_splits, nb.index)
        graph = csr_matrix((np.ones(len(nb.index)), nb.index, nb.row_splits), shape=(3000, 3000))
        count_sp, body_sp = connected_components(graph, directed=False)
        assert count == count_sp and len(set(zip(body.tolist(), body_sp.tolist()))) == count
    assert count == 1


def test_each_body_of_fluid_gets_its_own_level():
    """Three blocks of fluid more than a kernel support apart: each particle's level is the
    lowest surface particle of its own block (less the margin), a block without a surface
    particle gets the fill level: a puddle spilled beside a glass does not lower the glass's
    level (the 3-D cocktail's reference was off from 2 s on before)."""
    from dcdc.neighbors import radius_search
    from dcdc.sph.reference import surface_levels
    h, d = 0.04, 0.02
    blocks = [(0.0, 0.0), (1.0, -0.5), (2.0, 0.3)]  # (x, y) of each block's lower left
    x = np.concatenate([np.stack(np.meshgrid(x0 + d * np.arange(5), y0 + d * np.arange(4)),
                                 -1).reshape(-1, 2) for x0, y0 in blocks])
    body = np.repeat(np.arange(3), 20)
    top = np.isclose(x[:, 1], np.array([y0 for _, y0 in blocks])[body] + 3 * d)
    grad = np.zeros_like(x)
    grad[top & (body < 2), 1] = 1.0 / h  # blocks 0 and 1 have a free surface on top
    grad[(x[:, 0] > 1.01) & top & (body == 1), 1] = 0.0  # block 1: only its top-left one
    nb = radius_search(x, h)
    level = surface_levels(x, grad, h, np.array([0.0, -9.81]), nb.row_splits, nb.index,
                           fill=5.0, margin=d)
    np.testing.assert_allclose(level[body == 0], 3 * d - d)
    np.testing.assert_allclose(level[body == 1], -0.5 + 3 * d - d)
    np.testing.assert_allclose(level[body == 2], 5.0)


def test_reference_surface_settings():
    """reference_surface (the default) sets the level itself: an explicit one is an error
    that names the switch; without a reference_density it takes the share (AUTO_REFERENCE) of
    the lightest phase's; with both switches off and no reference_density there is no
    reference, and without gravity there is none either (q = 0)."""
    with pytest.raises(DcdcError, match="reference_surface = false"):
        SPHConfig(reference_level=1.0)
    assert SPHConfig().reference_surface is True
    sy = _closed_tank(0.02, lambda p: np.where(p[:, 1] < 0.15, 0, 1),
                      [Phase("heavy", 1500.0), Phase("light", 800.0)])
    assert Simulator(sy, SPHConfig())._reference[0] == pytest.approx(SHARE * 800.0)
    assert Simulator(sy, SPHConfig(reference_surface=False,
                                   reference_stratified=False))._reference is None
    # the layered reference is the default; an explicit reference_density is one ρ_ref for
    # every height (the built-in closed scenes), and without reference_surface the layers
    # hang from the fixed fill level
    assert SPHConfig().reference_stratified is True
    def follow(cfg):
        sim = Simulator(sy, cfg)
        s = sim._state(sim._active())
        return sim, sim._follow(s, sim._neighbourhood(s))
    assert follow(SPHConfig(reference_density=500.0, reference_surface=False))[1][::2] == (500.0, 0.0)
    sim, (rho_ref, level, dz) = follow(SPHConfig(reference_surface=False))
    assert level == sim._fill and dz == pytest.approx(0.04) and np.ndim(rho_ref) == 1
    sy.gravity = np.zeros(2)
    assert Simulator(sy, SPHConfig())._reference is None


@pytest.mark.slow
def test_an_open_tank_at_rest_is_unchanged_by_the_surface_reference():
    """With a free surface the level follows it, so q is a gauge there too: the quick
    hydrostatic case (an open tank) passes all its checks with it (the default)."""
    from dcdc.sph.cases import CASES
    rows = CASES["hydrostatic"](2, True, SPHConfig())
    checks = [r for r in rows if r.passed is not None]
    assert checks and all(r.passed for r in checks), [(r.quantity, r.measured) for r in checks]


@pytest.mark.slow
def test_the_surface_reference_frees_the_light_fluid_at_the_side_wall():
    """The full 2-D 2:1 collapse (512 particles, an open tank): without a reference 2 light
    particles (0.8 %) stay pressed against a side wall under the heavy layer (measured); with
    the surface-following reference, the default, none do, and the energy budget holds."""
    from dcdc.sph.cases import CASES
    rows = CASES["side_by_side_2to1"](2, False, SPHConfig())
    checks = [r for r in rows if r.passed is not None]
    assert all(r.passed for r in checks), [(r.quantity, r.measured) for r in checks]
    left = next(r for r in rows if r.quantity == "light left below the interface")
    assert left.measured == 0.0


@pytest.mark.slow
def test_the_layered_reference_lets_a_deep_film_rise():
    """The thin-film row's deep half at full 2-D resolution (r = 5 mm, 1 s): under 0.3 m of
    twice as dense fluid the 2 cm film stays on the floor with the default reference (rise
    −0.3 mm, measured), and rises with reference_stratified, whose slabs take out the heavy
    layer's level (24 mm measured; docs/sph.md, "A reference that follows the layers")."""
    from dcdc.sph.experiments import FILM, film_rise
    run = film_rise(2, 0.005, SPHConfig(reference_stratified=True), FILM["deep"])
    assert run["rise"] > 0.01, run


def test_an_aliased_empty_slab_inside_the_fluid_keeps_its_neighbours_density():
    """Rows one spacing apart leave a slab of one spacing empty when they sit on its faces:
    inside the fluid such a slab takes the lower of the densities above and below it (so q
    does not lose |g| ρ_ref d there), while slabs above the first occupied one stay 0."""
    from dcdc.sph.reference import fill_aliased_slabs, strata
    inf = np.inf
    np.testing.assert_array_equal(fill_aliased_slabs(np.array([inf, 1000., inf, 2000., inf, 1500.])),
                                  [0., 1000., 1000., 2000., 1500., 1500.])
    assert not fill_aliased_slabs(np.array([inf, inf])).any()
    # rows two slabs apart, as aliasing leaves them: every second slab holds none
    g = np.array([0.0, -9.81])
    d, level = 0.01, 1.0
    y = level - d * (2 * np.arange(30) + 0.5)
    prof = strata(np.c_[np.zeros(len(y)), y], np.full(len(y), 1000.0), g, level, d)
    assert prof[0] == SHARE * 1000.0 and np.all(prof == SHARE * 1000.0)
    q = reference_pressure(np.array([[0.0, 0.6]]), g, prof, level, d)[0]
    assert q == pytest.approx(SHARE * 1000.0 * 9.81 * 0.4)  # with the gaps at 0: half of it


def _closed_tank_with_a_void(r=0.0125):
    """The closed filled tank with a disc of 5 cm radius emptied 12 cm above its floor."""
    import dataclasses
    sy = _closed_tank(r, lambda p: np.zeros(len(p), int), [Phase("w", 1000.0)])
    keep = np.linalg.norm(sy.x - [0.2, 0.12], axis=1) > 0.05
    return dataclasses.replace(sy, x=sy.x[keep].copy(), v=sy.v[keep].copy(),
                               phase=sy.phase[keep].copy(), birth=None, death=None)


def test_with_suction_a_void_under_the_level_rises_and_the_total_pressure_stays_positive():
    """With the whole level in the reference (a closed tank, ρ_ref = ρ) the pair force sees
    no weight, so with the solves held at p' >= 0 a void 12 cm down is only slowly displaced;
    with ``reference_suction`` the solves may go down to p' = -q (total pressure >= 0) and the
    void rises as a bubble does: the fluid's mean height falls faster (measured after 1 s:
    -4.5 mm against -1.8 mm), with the total pressure >= 0 and the fluid calm."""
    fall = {}
    for suction in (False, True):
        sy = _closed_tank_with_a_void()
        y0 = sy.x[:, 1].mean()
        sim = Simulator(sy, SPHConfig(reference_density=1000.0, reference_level=0.3,
                                      reference_surface=False, reference_suction=suction))
        sim.run(1.0)
        fall[suction] = y0 - sy.x[:, 1].mean()
        assert sim.pressure().min() > -1.0  # Pa: the total, p' + q
        assert np.all(np.isfinite(sy.x)) and np.abs(sy.v).max() < 0.05
    assert fall[False] > 0 and fall[True] > 2.0 * fall[False], fall


def test_reference_share_and_suction_are_checked():
    with pytest.raises(DcdcError, match="reference_share"):
        SPHConfig(reference_share=1.5)
    with pytest.raises(DcdcError, match="reference_share"):
        SPHConfig(reference_share=0.0)
    with pytest.raises(DcdcError, match="reference_suction"):
        SPHConfig(reference_suction="yes")
