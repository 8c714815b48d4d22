"""The compiled pressure operator against a per-edge numpy reference, and its adjoint
property (docs/sph.md): the pressure force does no work on a flow that keeps ψ constant."""
import numpy as np
import pytest

from dcdc.sph.boundary import wall_volumes
from dcdc.sph.kernels import lattice_volume
from dcdc.sph.neighbourhood import build
from dcdc.sph.terms import compression_rate, pressure_acceleration, pressure_diagonal


def scene(dim, seed=0):
    """Jittered fluid block above a two-layer floor of wall particles, random p and v."""
    rng = np.random.default_rng(seed)
    r = 0.025
    s = 2 * r
    h = 4 * r
    n_side = 6
    axes = [np.arange(n_side) * s + s] * dim
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    x += rng.uniform(-0.2 * s, 0.2 * s, x.shape)
    wall_axes = [np.arange(-2, n_side + 2) * s] * dim
    wall_axes[1] = np.array([0.0, -s])
    wx = np.stack(np.meshgrid(*wall_axes, indexing="ij"), -1).reshape(-1, dim)
    V0 = lattice_volume(s, h, dim)
    Vb = wall_volumes(wx, h, V0)
    rho0 = np.where(x[:, 0] > x[:, 0].mean(), 1000.0, 100.0)
    p = rng.uniform(0.0, 500.0, len(x))
    v = rng.normal(0.0, 1.0, x.shape)
    return x, wx, Vb, V0, h, rho0, p, v


def reference(x, wx, Vb, V0, h, rho0, p, v, beta):
    """Per-edge numpy evaluation of the docstring formulas of dcdc.sph.terms."""
    nbh = build(x, wx, Vb, h, V0)
    recv = np.repeat(np.arange(len(x)), np.diff(nbh.rs))
    recvb = np.repeat(np.arange(len(x)), np.diff(nbh.rsb))
    j, b = nbh.idx, nbh.idxb
    a = np.zeros_like(x)
    np.add.at(a, recv, -(V0 * (p[recv] + p[j]) / rho0[recv])[:, None] * nbh.G)
    np.add.at(a, recvb, -(beta * p[recvb] * Vb[b] / rho0[recvb])[:, None] * nbh.Gb)
    rate = np.zeros(len(x))
    np.add.at(rate, recv, V0 * ((v[recv] - v[j]) * nbh.G).sum(1))
    np.add.at(rate, recvb, beta * Vb[b] * (v[recvb] * nbh.Gb).sum(1))
    return nbh, a, rate


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("beta", [1.0, 2.0])
def test_pressure_operator_matches_per_edge_reference(dim, beta):
    x, wx, Vb, V0, h, rho0, p, v = scene(dim)
    nbh, a_ref, rate_ref = reference(x, wx, Vb, V0, h, rho0, p, v, beta)
    assert nbh.rsb[-1] > 0  # the floor is within reach
    a = pressure_acceleration(p, rho0, nbh.rs, nbh.idx, nbh.G, nbh.Sb, V0, np.empty_like(x), beta)
    rate = compression_rate(v, nbh.rs, nbh.idx, nbh.G, nbh.Sb, V0, beta)
    np.testing.assert_allclose(a, a_ref, rtol=1e-12, atol=1e-9 * np.abs(a_ref).max())
    np.testing.assert_allclose(rate, rate_ref, rtol=1e-12, atol=1e-9 * np.abs(rate_ref).max())


@pytest.mark.parametrize("dim", [2, 3])
def test_pressure_force_is_the_negative_adjoint_of_the_compression_rate(dim):
    """Σ_i V0 p_i Dψ_i/Dt(v) = -Σ_i v_i·F_i(p) with F_i = ρ0_i V0 a_i (β = 1), hence the
    pressure matrix A: p -> Dψ/Dt(a(p)) is symmetric, and its diagonal is the one CG uses."""
    x, wx, Vb, V0, h, rho0, p, v = scene(dim, seed=1)
    nbh = build(x, wx, Vb, h, V0)
    args = (nbh.rs, nbh.idx, nbh.G, nbh.Sb, V0)
    a = pressure_acceleration(p, rho0, *args, np.empty_like(x), 1.0)
    rate = compression_rate(v, *args, 1.0)
    lhs = V0 * (p * rate).sum()
    rhs = -((rho0 * V0)[:, None] * v * a).sum()
    assert abs(lhs - rhs) < 1e-10 * (abs(lhs) + abs(rhs))

    def A(q):
        return compression_rate(pressure_acceleration(q, rho0, *args, np.empty_like(x), 1.0),
                                *args, 1.0)
    rng = np.random.default_rng(2)
    q = rng.uniform(0.0, 500.0, len(x))
    assert abs(q @ A(p) - p @ A(q)) < 1e-10 * abs(q @ A(p))
    e = np.zeros(len(x))
    diag = pressure_diagonal(rho0, *args, 1.0)
    for i in (0, len(x) // 2, len(x) - 1):
        e[:] = 0.0
        e[i] = 1.0
        assert A(e)[i] == pytest.approx(diag[i], rel=1e-10)


@pytest.mark.parametrize("dim", [2, 3])
def test_walls_share_of_psi_is_the_wall_particles_sum(dim):
    """ψ_i = V0 Σ_j W_ij + Ψ_b,i with the walls' share Ψ_b,i = Σ_b V_b W_ib kept apart
    (``psi_wall``, the wall images' distance from the wall), per-edge numpy reference."""
    x, wx, Vb, V0, h, *_ = scene(dim)
    nbh = build(x, wx, Vb, h, V0)
    recv, recvb = (np.repeat(np.arange(len(x)), np.diff(r)) for r in (nbh.rs, nbh.rsb))
    fluid = np.bincount(recv, weights=V0 * nbh.W, minlength=len(x))
    walls = np.bincount(recvb, weights=Vb[nbh.idxb] * nbh.Wb, minlength=len(x))
    assert walls.max() > 0.1  # the lowest row sits a spacing above the floor
    np.testing.assert_allclose(nbh.psi_wall, walls, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(nbh.psi, fluid + walls, rtol=1e-12)
