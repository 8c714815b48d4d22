"""The XSPH filter acts on a smooth shear like the viscosity ``forces.xsph_viscosity``."""
import numpy as np
import pytest

from dcdc.sph.forces import xsph_viscosity
from dcdc.sph.kernels import lattice_volume
from dcdc.sph.neighbourhood import build
from dcdc.sph.terms import xsph_velocity_change


@pytest.mark.parametrize("dim", [2, 3])
def test_xsph_decays_a_shear_wave_like_its_viscosity(dim):
    """u_x = sin(k y) on a lattice: one filter pass changes u by −ν k² Δt u in the interior,
    ν = xsph_viscosity (to 5 % at 16 spacings per wavelength); a uniform flow is unchanged."""
    r, eps, dt = 0.01, 0.1, 1e-3
    s, h = 2 * r, 4 * r
    n = 20 if dim == 2 else 12
    axes = [np.arange(n) * s] * dim
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    V0 = lattice_volume(s, h, dim)
    nbh = build(x, np.zeros((0, dim)), np.zeros(0), h, V0)
    k = 2 * np.pi / (16 * s)
    v = np.zeros_like(x)
    v[:, 0] = np.sin(k * x[:, 1])
    dv = xsph_velocity_change(v, np.full(len(x), 1000.0), np.zeros(len(x), np.int32), False,
                              nbh.rs, nbh.idx, nbh.W, V0, eps)
    inner = np.all((x > h - 1e-9) & (x < (n - 1) * s - h + 1e-9), axis=1)
    inner &= np.abs(v[:, 0]) > 0.5
    nu = xsph_viscosity(eps, r, 4.0, dt, dim)
    rate = -dv[inner, 0] / (v[inner, 0] * k * k * dt)
    np.testing.assert_allclose(rate, nu, rtol=0.05)
    uniform = np.full_like(x, 0.3)
    assert np.abs(xsph_velocity_change(uniform, np.full(len(x), 1000.0), np.zeros(len(x), np.int32),
                                       False, nbh.rs, nbh.idx, nbh.W, V0, eps)).max() < 1e-12
