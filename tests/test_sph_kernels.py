"""Kernel normalisation and gradients, Akinci volumes, the rest volume of the lattice."""
import numpy as np
import pytest

from dcdc.geometry import lattice
from dcdc.sph.boundary import wall_volumes
from dcdc.sph.kernels import cubic, cubic_grad, lattice_volume


@pytest.mark.parametrize("dim", [2, 3])
def test_cubic_spline_integrates_to_one(dim):
    h = 0.1
    dx = h / 40 if dim == 2 else h / 25
    ax = np.arange(-h, h + dx / 2, dx)
    g = np.meshgrid(*([ax] * dim), indexing="ij")
    r = np.sqrt(sum(c ** 2 for c in g)).ravel()
    total = cubic(r, h, dim).sum() * dx ** dim
    assert total == pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("dim", [2, 3])
def test_cubic_gradient_matches_finite_differences(dim):
    rng = np.random.default_rng(0)
    h = 0.1
    x = rng.uniform(-0.09, 0.09, (50, dim)) / np.sqrt(dim)
    g = cubic_grad(x, h)
    eps = 1e-6
    for k in range(dim):
        e = np.zeros(dim)
        e[k] = eps
        fd = (cubic(np.linalg.norm(x + e, axis=1), h, dim)
              - cubic(np.linalg.norm(x - e, axis=1), h, dim)) / (2 * eps)
        np.testing.assert_allclose(g[:, k], fd, rtol=1e-5, atol=1e-3)
    # compact support, zero gradient at the centre
    assert cubic(np.array([h, 1.5 * h]), h, dim).tolist() == [0.0, 0.0]
    assert np.all(cubic_grad(np.zeros((1, dim)), h) == 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_lattice_volume_makes_the_rest_lattice_psi_one(dim):
    s, h = 0.05, 0.1
    V0 = lattice_volume(s, h, dim)
    assert V0 == pytest.approx(s ** dim, rel=2e-3)
    pts = lattice(-3 * s * np.ones(dim), 3 * s * np.ones(dim), s)
    r = np.linalg.norm(pts, axis=1)
    assert V0 * cubic(r, h, dim).sum() == pytest.approx(1.0, abs=1e-12)


def test_akinci_volumes_of_a_multilayer_wall_equal_the_fluid_volume():
    s, h = 0.05, 0.1
    V0 = lattice_volume(s, h, 2)
    wall = lattice([-1, -0.1], [1, 0], s)  # three layers
    vol = wall_volumes(wall, h, V0)
    inner = np.abs(wall[:, 0]) < 0.8
    assert np.allclose(vol[inner], V0, rtol=1e-6)
    raw = wall_volumes(wall, h)  # uncapped Akinci: the open face gets larger volumes
    assert raw[inner & (wall[:, 1] > -1e-9)].min() > 1.05 * V0
