"""The Smagorinsky eddy viscosity (``SPHConfig.smagorinsky``): the SPH strain rate it is
built from, and that it only ever removes kinetic energy."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.particles import Phase
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.fixtures import one_phase, tank_system
from dcdc.sph.kernels import lattice_volume
from dcdc.sph.neighbourhood import build
from dcdc.sph.terms import strain_rate, viscosity_acceleration


def _lattice(dim, n=9, r=0.025):
    s, h = 2 * r, 4 * r
    axes = [np.arange(n) * s] * dim
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    inner = np.all((x > 2 * s - 1e-9) & (x < (n - 3) * s + 1e-9), axis=1)  # a support inside
    V0 = lattice_volume(s, h, dim)
    nbh = build(x, np.zeros((0, dim)), np.zeros(0), h, V0)
    return x, inner, nbh, V0


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_strain_rate_of_linear_flows(dim):
    """|S| = sqrt(2 S:S): γ for a simple shear u = γ y; 0 for a uniform flow and for a rigid
    rotation (whose velocity gradient is antisymmetric), in the lattice's interior."""
    x, inner, nbh, V0 = _lattice(dim)
    gamma = 3.0
    shear = np.zeros_like(x)
    shear[:, 0] = gamma * x[:, 1]
    S = strain_rate(shear, nbh.rs, nbh.idx, nbh.G, V0)
    np.testing.assert_allclose(S[inner], gamma, rtol=0.03)
    uniform = np.ones_like(x) * 0.7
    assert np.abs(strain_rate(uniform, nbh.rs, nbh.idx, nbh.G, V0)).max() < 1e-12
    rot = np.zeros_like(x)
    rot[:, 0], rot[:, 1] = -gamma * x[:, 1], gamma * x[:, 0]
    assert strain_rate(rot, nbh.rs, nbh.idx, nbh.G, V0)[inner].max() < 1e-6 * gamma


@pytest.mark.parametrize("dim", [2, 3])
def test_eddy_viscosity_force_conserves_momentum_and_dissipates(dim):
    """With ν_t = (C_s 2r)² |S| in the Morris term the viscous forces of a random flow sum to
    zero (momentum) and their power Σ m_i v_i·a_i is negative (they only remove energy)."""
    x, inner, nbh, V0 = _lattice(dim, n=7)
    rng = np.random.default_rng(1)
    v = rng.normal(0.0, 0.1, x.shape)
    rho0 = np.where(x[:, 0] > x[:, 0].mean(), 2000.0, 1000.0)
    l2 = (0.12 * 0.05) ** 2
    mu = rho0 * l2 * strain_rate(v, nbh.rs, nbh.idx, nbh.G, V0)
    assert (mu > 0).all()
    one_phase = np.zeros(len(x), np.int32)
    a = viscosity_acceleration(x, v, rho0, mu, mu, one_phase, False, nbh.rs, nbh.idx, nbh.G,
                               np.zeros((0, dim)),
                               nbh.rsb, nbh.idxb, nbh.Gb, np.zeros(0), V0, 0.1)
    m = rho0 * V0
    force = (m[:, None] * a).sum(0)
    assert np.abs(force).max() < 1e-10 * np.abs(m[:, None] * a).sum()
    assert (m[:, None] * v * a).sum() < 0.0


def test_eddy_viscosity_damps_particle_scale_motion():
    """A closed 2-D box without gravity with random particle-scale velocities keeps less
    kinetic energy after 1 s with C_s = 0.4 than without (measured 0.054 against 0.096; the
    standard C_s = 0.12 keeps 0.085)."""
    r = 0.025
    sy = tank_system(2, r, [0.4, 0.4], [(np.zeros(3), [0.4, 0.4, 0], one_phase(0))],
                     [Phase("w", 1000.0)], closed=True)
    sy.gravity[:] = 0.0
    sy.v[:] = np.random.default_rng(0).normal(0.0, 0.05, sy.v.shape)
    ke = {}
    for cs in (0.0, 0.4):
        s2 = sy.copy()
        Simulator(s2, SPHConfig(xsph=0.0, viscosity=0.0, smagorinsky=cs)).run(1.0)
        ke[cs] = float((s2.v ** 2).sum())
    assert ke[0.4] < 0.7 * ke[0.0]


def test_smagorinsky_must_be_non_negative():
    with pytest.raises(DcdcError, match="smagorinsky"):
        SPHConfig(smagorinsky=-0.1)
