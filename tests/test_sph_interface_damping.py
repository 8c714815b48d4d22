"""``SPHConfig.interface_damping = false``: the artificial viscosity and XSPH act within each
phase only, unlike phases are coupled by their own viscosities (docs/sph.md, "Interface
damping")."""
import numpy as np
import pytest

from dcdc.sph.forces import smooth_velocity
from dcdc.sph.kernels import lattice_volume
from dcdc.sph.neighbourhood import build
from dcdc.sph.state import State
from dcdc.sph.terms import viscosity_acceleration


def _two_layers(dim, n=8, r=0.025):
    s, h = 2 * r, 4 * r
    axes = [np.arange(n) * s] * dim
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    upper = x[:, 1] > x[:, 1].mean()
    phase = upper.astype(np.int32)
    rho0 = np.where(upper, 1000.0, 2000.0)
    V0 = lattice_volume(s, h, dim)
    nbh = build(x, np.zeros((0, dim)), np.zeros(0), h, V0)
    return x, phase, rho0, nbh, V0, h


def _state(x, v, phase, rho0, mu, mu_cross, V0, h):
    d = x.shape[1]
    return State(x, v, phase, rho0, mu, np.zeros(len(x)), np.zeros(len(x)), np.zeros((0, d)),
                 np.zeros(0), np.zeros(d), V0, h, mu_cross=mu_cross)


@pytest.mark.parametrize("dim", [2, 3])
def test_slip_between_phases_is_not_damped_without_interface_damping(dim):
    """Two layers sliding past each other (each uniform): with interface damping the
    artificial viscosity and XSPH pull the layers together; without it (and inviscid
    phases) neither acts, while a shear inside one phase is still damped."""
    x, phase, rho0, nbh, V0, h = _two_layers(dim)
    slip = np.zeros_like(x)
    slip[:, 0] = np.where(phase == 1, 0.5, -0.5)
    mu = rho0 * 1e-3  # artificial only (inviscid phases)
    zero = np.zeros(len(x))
    args = (nbh.rs, nbh.idx, nbh.G, np.zeros((0, dim)), nbh.rsb, nbh.idxb, nbh.Gb, np.zeros(0),
            V0, h)
    a_on = viscosity_acceleration(x, slip, rho0, mu, mu, phase, False, *args)
    a_off = viscosity_acceleration(x, slip, rho0, mu, zero, phase, False, *args)
    assert np.abs(a_on[:, 0]).max() > 0.1
    assert np.abs(a_off).max() == 0.0
    for mu_cross, damped in ((None, True), (zero, False)):
        s = _state(x, slip.copy(), phase, rho0, mu, mu_cross, V0, h)
        smooth_velocity(s, nbh, 0.1)
        change = np.abs(s.v - slip).max()
        assert (change > 1e-3) if damped else (change == 0.0), change
    # a shear inside the lower phase is damped either way, conserving momentum
    shear = np.zeros_like(x)
    shear[:, 0] = np.where(phase == 0, np.sin(7.0 * x[:, 1]), 0.0)
    a = viscosity_acceleration(x, shear, rho0, mu, zero, phase, False, *args)
    assert np.abs(a[phase == 0]).max() > 0.3 * 1e-3 * 7.0 ** 2  # ν k² of the sine
    s = _state(x, shear.copy(), phase, rho0, mu, zero, V0, h)
    smooth_velocity(s, nbh, 0.1)
    m = rho0[:, None]
    np.testing.assert_allclose((m * s.v).sum(0), (m * shear).sum(0), atol=1e-9)
    np.testing.assert_allclose((m * a).sum(0), 0.0, atol=1e-6 * np.abs(m * a).sum())
