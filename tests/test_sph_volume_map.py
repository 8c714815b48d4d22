"""The walls' volume map (dcdc.sph.volume_map): consistent with the rest lattice, smooth
along a wall (no grip), its gradient the derivative of its value."""
import numpy as np
import pytest

from dcdc.particles import Phase
from dcdc.sph import volume_map as VM
from dcdc.sph.fixtures import one_phase, tank_system
from dcdc.sph.kernels import lattice_volume

R = 0.025
H = 4 * R


def _tank(dim):
    size = [0.4, 0.4, 0.2][:dim]
    return tank_system(dim, R, size, [(np.zeros(3), [0.4, 0.4, 0.2], one_phase(0))],
                       [Phase("w", 1000.0)], wall_height=0.6)


def _maps(sy):
    off = VM.wall_offset(R, H, sy.dim, lattice_volume(2 * R, H, sy.dim))
    return (VM.from_sdf(sy.wall_sdf, sy.wall_x, *sy.domain, R, H, off),
            VM.from_particles(sy.wall_x, *sy.domain, R, H, off))


@pytest.mark.parametrize("dim", [2, 3])
def test_rest_lattice_keeps_unit_density_at_a_flat_floor(dim):
    """ψ of the first fluid row on the floor (away from the side walls) is 1 within 0.3 %
    (the offset makes the map consistent with the fluid's discrete sum)."""
    from dcdc.sph import Simulator, SPHConfig

    sy = _tank(dim)
    sim = Simulator(sy, SPHConfig())
    psi = sim.density() / 1000.0
    floor = (sy.x[:, 1] < 2 * R) & (np.abs(sy.x[:, 0] - 0.2) < 0.08)
    if dim == 3:
        floor &= np.abs(sy.x[:, 2] - 0.1) < 0.03
    assert floor.sum() >= 3
    assert np.abs(psi[floor] - 1.0).max() < 3e-3


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_no_ripple_along_a_flat_wall(dim):
    """Along the floor, the tangential gradient of Ψ is < 0.5 % of its normal gradient for
    both constructions (wall particles ripple by 1 % at the rest height, more below it)."""
    sy = _tank(dim)
    xs = np.linspace(0.15, 0.25, 41)
    for height in (R, 0.5 * R):
        P = np.zeros((41, dim))
        P[:, 0] = xs
        P[:, 1] = height
        if dim == 3:
            P[:, 2] = 0.1
        for vm in _maps(sy):
            psi, g = vm.sample(P)
            assert np.ptp(psi) < 1e-4
            assert np.abs(g[:, 0]).max() < 5e-3 * np.abs(g[:, 1]).mean()


def test_sdf_and_particle_maps_agree():
    sy = _tank(2)
    a, b = _maps(sy)
    pa, _ = a.sample(sy.x)
    pb, _ = b.sample(sy.x)
    assert np.abs(pa - pb).max() < 0.01


def test_gradient_is_the_derivative_of_the_value():
    sy = _tank(2)
    vm, _ = _maps(sy)
    rng = np.random.default_rng(0)
    P = np.column_stack([rng.uniform(-0.02, 0.42, 50), rng.uniform(-0.02, 0.15, 50)])
    _, g = vm.sample(P)
    eps = 1e-6
    for a in range(2):
        e = np.zeros(2)
        e[a] = eps
        fd = (vm.sample(P + e)[0] - vm.sample(P - e)[0]) / (2 * eps)
        assert np.allclose(g[:, a], fd, atol=1e-4 * np.abs(g).max())


def test_deep_solid_is_full_and_far_fluid_empty():
    sy = _tank(2)
    vm, _ = _maps(sy)
    psi, _ = vm.sample(np.array([[0.2, -3.5 * R], [0.2, 0.3]]))
    assert psi[0] > 0.98 and psi[1] < 1e-6


def test_half_space_profile_is_one_half_at_the_surface():
    for dim in (2, 3):
        z, psi = VM.half_space_profile(H, dim)
        assert psi[0] == pytest.approx(0.5, abs=2e-3)
        assert psi[-1] == pytest.approx(0.0, abs=1e-9)
        assert np.all(np.diff(psi) <= 1e-12)


def test_contact_moves_points_out_of_the_solid_and_stops_them_entering():
    """VolumeMap.keep_outside: a point inside the floor goes back to Ψ = 1/2, loses its
    velocity into the floor and keeps its velocity along it; fluid outside is untouched."""
    sy = _tank(2)
    vm = _maps(sy)[0]
    x = np.array([[0.2, -0.4 * R], [0.25, -0.2 * R], [0.2, 1.0 * R]])
    v = np.array([[1.0, -2.0], [0.0, -1.0], [0.5, -3.0]])
    x0, v0 = x.copy(), v.copy()
    assert (vm.sample(x)[0][:2] > 0.5).all()
    assert vm.keep_outside(x, v) == 2
    psi, grad = vm.sample(x)
    assert np.abs(psi[:2] - 0.5).max() < 2e-3
    assert np.abs(x[:2, 0] - x0[:2, 0]).max() < 1e-3 * R  # pushed straight up, out of the floor
    assert (x[:2, 1] > x0[:2, 1]).all()
    np.testing.assert_allclose(v[:2, 1], 0.0, atol=1e-3)   # no velocity into the floor
    np.testing.assert_allclose(v[:2, 0], v0[:2, 0], atol=1e-3)  # free slip along it
    np.testing.assert_array_equal(x[2], x0[2])
    np.testing.assert_array_equal(v[2], v0[2])
