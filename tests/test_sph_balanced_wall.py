"""The balanced wall (`sph.wall_contact_support`, dcdc.sph.volume_map.balanced_wall): the
walls' share Φ = Ψ + A Ψ_c keeps the rest lattice at ψ = 1, balances a uniform pressure on
the first row (the plain map pulls it into the wall), stays a gradient field (so the force
stays the adjoint of the compression rate), and holds a floor row at rest near r."""
import math

import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.particles import Phase
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph import volume_map as VM
from dcdc.sph.fixtures import one_phase, tank_system
from dcdc.sph.dfsph import _acceleration

R = 0.025


def _tank(dim, r=R, size=(0.4, 0.4, 0.2)):
    size = list(size)[:dim]
    return tank_system(dim, r, size, [(np.zeros(3), [0.4, 0.4, 0.2], one_phase(0))],
                       [Phase("w", 1000.0)], wall_height=0.6)


def _floor_row(sy, dim):
    """First-row particles on the floor, a support away from the side walls."""
    sel = (sy.x[:, 1] < 2 * R) & (np.abs(sy.x[:, 0] - 0.2) < 0.08)
    if dim == 3:
        sel &= np.abs(sy.x[:, 2] - 0.1) < 0.03
    assert sel.sum() >= 3
    return sel


@pytest.mark.parametrize("dim", [2, 3])
def test_balanced_wall_keeps_the_rest_lattice_and_balances_a_uniform_pressure(dim):
    """On the rest lattice ψ of the floor row is 1 within 0.3 % with either wall, and a
    uniform pressure p accelerates that row by < 3 % of p/(ρ0 r) with the balanced wall,
    against ≈ 0.29 p/(ρ0 r) into the floor with the plain map (computed in
    balanced_wall's docstring; here through the solver's own sampled map and operators)."""
    sy = _tank(dim)
    floor = _floor_row(sy, dim)
    p0 = 1000.0
    scale = p0 / (1000.0 * R)
    out = {}
    for support in (0.0, 2.0):
        sim = Simulator(sy.copy(), SPHConfig(wall_contact_support=support))
        psi = sim.density() / 1000.0
        assert np.abs(psi[floor] - 1.0).max() < 3e-3
        s = sim._state(None)
        nbh = sim._neighbourhood(s)
        a = _acceleration(s, nbh, np.full(sy.n_fluid, p0), np.empty_like(s.x))
        out[support] = a[floor, 1].mean() / scale
    assert out[0.0] < -0.2          # the plain map pulls the row into the floor
    assert abs(out[2.0]) < 0.03     # the balanced one does not


def test_balanced_field_is_a_gradient():
    """∇Φ is the derivative of Φ (so p_i ∇Φ is the adjoint of the rate ∇Φ·v: no work
    done on a flow that keeps ψ constant), and Φ exceeds Ψ only within 2r of the wall."""
    sy = _tank(2)
    vm = VM.for_system(sy, 4 * R, Simulator(sy, SPHConfig()).V0, contact_support=2.0)
    rng = np.random.default_rng(0)
    # the fluid side of the floor and side walls (inside the solid the contact moves
    # particles out, VolumeMap.keep_outside)
    P = np.column_stack([rng.uniform(0.0, 0.4, 60), rng.uniform(0.0, 0.15, 60)])
    phi, g = vm.sample(P)
    eps = 1e-5  # Ψ's table is float32 (volume_map._convolve): a smaller step sees its rounding
    for a in range(2):
        e = np.zeros(2)
        e[a] = eps
        fd = (vm.sample(P + e)[0] - vm.sample(P - e)[0]) / (2 * eps)
        assert np.allclose(g[:, a], fd, atol=1e-3 * np.abs(g).max())
    psi, _ = vm._interp(vm.psi, P)
    far = (P[:, 0] > 3 * R) & (P[:, 0] < 0.4 - 3 * R) & (P[:, 1] > 3 * R)
    assert far.sum() > 5
    np.testing.assert_allclose(phi[far], psi[far], atol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_offset_and_amplitude_solve_both_conditions(dim):
    """balanced_wall's δ and A satisfy ψ_f + Φ = 1 and ∂Φ/∂z = -2 ∂ψ_f/∂z at the first row,
    for several contact supports."""
    from dcdc.sph.kernels import lattice_volume

    h = 4.0
    V0 = lattice_volume(2.0, h, dim)
    psi_f, slope_f = VM._first_row(1.0, h, dim, V0)
    z, psi = VM.half_space_profile(h, dim, 4001)
    for support in (1.5, 2.0, 3.0):
        off, amp = VM.balanced_wall(1.0, h, dim, V0, support)
        z1 = 1.0 + off
        phi = lambda zz: np.interp(zz, z, psi) + amp * VM.contact_profile(zz, support, dim)  # noqa: E731
        assert psi_f + phi(z1) == pytest.approx(1.0, abs=2e-4)
        d = 1e-3
        assert (phi(z1 + d) - phi(z1 - d)) / (2 * d) == pytest.approx(-2.0 * slope_f, rel=0.02)


@pytest.mark.slow
def test_floor_row_stays_near_its_lattice_height_without_damping():
    """A 2-D tank at rest without XSPH and artificial viscosity: after 0.5 s the floor row
    sits at ≥ 0.9 r with the balanced wall (the plain map: it sinks to ~0.35 r)."""
    r = 0.0125
    sy = tank_system(2, r, [0.5, 0.5], [(np.zeros(3), [0.5, 0.5, 0], one_phase(0))],
                     [Phase("w", 1000.0)], wall_height=0.7)
    heights = {}
    for support in (0.0, 2.0):
        s2 = sy.copy()
        sim = Simulator(s2, SPHConfig(xsph=0.0, viscosity=0.0, wall_contact_support=support))
        sim.run(0.5)
        row = np.sort(s2.x[:, 1])[: int(0.8 * 0.5 / (2 * r))]
        heights[support] = row.mean() / r
    assert heights[0.0] < 0.6
    assert heights[2.0] > 0.9


def test_balanced_wall_needs_the_walls_signed_distance():
    sy = _tank(2)
    sy.wall_sdf = None
    with pytest.raises(DcdcError, match="signed distance"):
        Simulator(sy, SPHConfig(wall_contact_support=2.0))
    with pytest.raises(DcdcError, match="wall_contact_support"):
        SPHConfig(wall_contact_support=-1.0)
    with pytest.raises(DcdcError, match="exceed"):
        VM.balanced_wall(R, 4 * R, 2, (2 * R) ** 2, 1.0)
    assert math.isfinite(VM.balanced_wall(R, 4 * R, 2, (2 * R) ** 2, 2.0)[1])
