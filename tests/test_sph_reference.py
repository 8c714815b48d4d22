"""The hydrostatic reference pressure (SPHConfig.reference_density, dcdc.sph.reference)."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.particles import Phase
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.cases import EnergyBudget, run, tank_system
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


def _closed_tank(r, phase_of, phases):
    W, H = 0.4, 0.3
    return tank_system(2, r, (W, H), [((0, 0), (W, H), phase_of)], phases, wall_height=H,
                       closed=True)


def test_reference_above_the_lightest_phase_is_an_error():
    sy = _closed_tank(0.02, lambda p: np.zeros(len(p), int), [Phase("w", 1000.0)])
    with pytest.raises(DcdcError, match="lightest"):
        Simulator(sy, SPHConfig(reference_density=1200.0, reference_level=0.3))


@pytest.mark.slow
def test_a_closed_filled_tank_at_rest_is_unchanged():
    """In a container without a free surface q is a gauge: the reported pressure p' + q has
    the hydrostatic slope and the fluid stays at rest."""
    out = {}
    for rho_ref in (0.0, 1000.0):
        sy = _closed_tank(0.0125, lambda p: np.zeros(len(p), int), [Phase("w", 1000.0)])
        sim = Simulator(sy, SPHConfig(reference_density=rho_ref, reference_level=0.3))
        sim.run(1.0)
        y, p = sy.x[:, 1], sim.pressure()
        inner = (y > 0.1) & (y < 0.2) & (sy.x[:, 0] > 0.1) & (sy.x[:, 0] < 0.3)
        slope = np.polyfit(y[inner], p[inner], 1)[0]
        out[rho_ref] = (slope / (-1000.0 * 9.81), float(np.abs(sy.v).max()))
    # with the reference the solves only see p - q ~ 0: hydrostatic and still (measured
    # slope 1.0000, 1.4e-5 m/s); without it the same physics within 10 % (0.94, 0.06 m/s:
    # the lid's row sits under the pair sum's level term)
    slope, vmax = out[1000.0]
    assert abs(slope - 1.0) < 0.02 and vmax < 0.005, out
    slope, vmax = out[0.0]
    assert abs(slope - 1.0) < 0.1 and vmax < 0.1, out


@pytest.mark.slow
def test_energy_budget_holds_with_the_reference():
    """Heavy over light in a closed filled box with the reference: the body force is an
    external potential whose energy is constant when the box stays filled, so the kinetic
    energy never exceeds the gravitational energy released."""
    sy = _closed_tank(0.01, lambda p: np.where(p[:, 1] > 0.15 + 0.03 * np.cos(2 * np.pi * p[:, 0] / 0.4),
                                             0, 1), [Phase("heavy", 2000.0), Phase("light", 1000.0)])
    sim = Simulator(sy, SPHConfig(reference_density=1000.0, reference_level=0.3))
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
    assert Simulator(sy, SPHConfig(reference_density=800.0))._reference == (800.0, top)
    assert Simulator(sy, SPHConfig(reference_density=800.0, reference_level=0.5))._reference[1] == 0.5


def test_reference_level_settings():
    """None (unset) and numbers are accepted and survive a round trip; anything else is a
    one-line error."""
    assert SPHConfig.from_dict({}).reference_level is None
    assert SPHConfig.from_dict({"reference_level": 1}).reference_level == 1.0
    c = SPHConfig(reference_density=500.0)
    assert SPHConfig.from_dict(c.to_dict()) == c
    for bad in ("top", float("nan"), True):
        with pytest.raises(DcdcError, match="reference_level"):
            SPHConfig.from_dict({"reference_level": bad})


def test_the_built_in_closed_scenes_carry_the_closed_settings():
    """lock_exchange and hourglass are filled up to their lids: they run with the
    closed-container damping that the validation's lock-exchange rows check
    (dcdc.sph.reference.closed_container) and a reference of their light phase's density
    (the box, filled with whole rows) or 0.9 of it (the hourglass, whose lattice leaves gaps
    at the shoulders that must be able to rise)."""
    from dcdc.scene import get_scene
    from dcdc.sph.reference import closed_container
    for name, share in (("lock_exchange", 1.0), ("hourglass", 0.9)):
        scene = get_scene(name)
        light = min(p["density"] for p in scene.data["phases"].values())
        assert scene.check_solver() == SPHConfig.from_dict(closed_container({}, share * light)), name


def test_surface_level_finds_the_lowest_free_surface_particle():
    """An open tank on the rest lattice: its free surface is the top row (the level is the top
    row's height), the particles at the floor and side walls are not at a surface; the same
    tank closed and filled up to its lid has no free surface (None)."""
    from dcdc.sph.neighbourhood import build
    from dcdc.sph.reference import surface_level
    from dcdc.sph.terms import psi_gradient
    W, H, r = 0.4, 0.2, 0.01
    for closed, expect in ((False, H - r), (True, None)):  # the top row's centre
        sy = tank_system(2, r, (W, H), [((0, 0), (W, H), lambda p: np.zeros(len(p), int))],
                         [Phase("w", 1000.0)], wall_height=H, closed=closed)
        sim = Simulator(sy, SPHConfig())
        s = sim._state(None)
        nbh = build(s.x, sim._walls, sim.Vb, sim.h, sim.V0, sim.volume_map, sim._wall_edges)
        level = surface_level(s.x, psi_gradient(nbh.rs, nbh.G, nbh.Sb, sim.V0), sim.h, s.gravity)
        if expect is None:
            assert level is None
        else:
            assert abs(level - expect) < 1e-9, level


def test_reference_surface_settings():
    """reference_surface sets the level itself (an explicit one is an error); without a
    reference_density it takes 0.9 of the lightest phase's."""
    with pytest.raises(DcdcError, match="reference_surface"):
        SPHConfig(reference_surface=True, reference_level=1.0)
    sy = _closed_tank(0.02, lambda p: np.where(p[:, 1] < 0.15, 0, 1),
                      [Phase("heavy", 1500.0), Phase("light", 800.0)])
    assert Simulator(sy, SPHConfig(reference_surface=True))._reference[0] == pytest.approx(720.0)


@pytest.mark.slow
def test_an_open_tank_at_rest_is_unchanged_by_the_surface_reference():
    """With a free surface the level follows it, so q is a gauge there too: the quick
    hydrostatic case (an open tank) passes all its checks with the option on."""
    from dcdc.sph.cases import CASES
    rows = CASES["hydrostatic"](2, True, SPHConfig(reference_surface=True))
    checks = [r for r in rows if r.passed is not None]
    assert checks and all(r.passed for r in checks), [(r.quantity, r.measured) for r in checks]


@pytest.mark.slow
def test_the_surface_reference_frees_the_light_fluid_at_the_side_wall():
    """The full 2-D 2:1 collapse (512 particles, an open tank): with the defaults 2 light
    particles (0.8 %) stay pressed against a side wall under the heavy layer; with the
    surface-following reference none do, and the energy budget holds."""
    from dcdc.sph.cases import CASES
    rows = CASES["side_by_side_2to1"](2, False, SPHConfig(reference_surface=True))
    checks = [r for r in rows if r.passed is not None]
    assert all(r.passed for r in checks), [(r.quantity, r.measured) for r in checks]
    left = next(r for r in rows if r.quantity == "light left below the interface")
    assert left.measured == 0.0
