"""Interfacial tension between phase pairs (dcdc.sph.interfaces)."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.particles import Phase
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.interfaces import lattice_across_sum, pair_coefficients
from dcdc.sph.kernels import lattice_volume

PH = [Phase("oil", 700.0), Phase("water", 1000.0), Phase("juice", 1400.0)]


def test_coefficients_are_symmetric_repulsive_and_proportional_to_sigma():
    h, V0 = 0.1, lattice_volume(0.05, 0.1, 2)
    K = pair_coefficients({"oil/water": 2.0, "water/juice": 1.0}, PH, h, V0, 2)
    assert np.allclose(K, K.T) and np.all(np.diag(K) == 0)
    assert K[0, 1] < 0 and K[1, 2] < 0 and K[0, 2] == 0
    assert K[0, 1] == pytest.approx(2 * K[1, 2])
    assert pair_coefficients({}, PH, h, V0, 2) is None


def test_lattice_sum_is_about_half_the_continuum_integral():
    from dcdc.sph.interfaces import across_integral
    for dim in (2, 3):
        V0 = lattice_volume(0.05, 0.1, dim)
        ratio = lattice_across_sum(0.025, 0.1, dim) / (across_integral(0.1, dim) / V0 ** 2)
        assert 0.45 < ratio < 0.6


@pytest.mark.parametrize("bad, msg", [({"oil/milk": 1.0}, "no phase 'milk'"),
                                      ({"oil/oil": 1.0}, "two different phases"),
                                      ({"oil": 1.0}, "two different phases")])
def test_bad_pairs_are_one_line_errors(bad, msg):
    with pytest.raises(DcdcError, match=msg):
        pair_coefficients(bad, PH, 0.1, 0.0025, 2)


@pytest.mark.parametrize("bad", [{"a/b": -1.0}, {"a/b": float("nan")}, {"a/b": "x"}, "a/b=1"])
def test_config_rejects_bad_tensions(bad):
    with pytest.raises(DcdcError, match="interfacial_tension"):
        SPHConfig(interfacial_tension=bad)


def test_interface_force_conserves_momentum_and_separates():
    """Two interleaved phases (no walls, no gravity): the pairwise repulsion keeps the total
    momentum zero and raises the fraction of same-phase neighbours."""
    from dcdc import metrics
    from dcdc.geometry import fill_box
    r = 0.02
    x = fill_box([0, 0], [0.4, 0.4], 2 * r)
    phase = np.random.default_rng(1).integers(0, 2, len(x))  # a random emulsion
    from dcdc.particles import ParticleSystem
    sy = ParticleSystem(2, r, x, np.zeros_like(x), phase, [Phase("a", 1000.0), Phase("b", 500.0)],
                        np.zeros((0, 2)), np.zeros((0, 2)), [0, 0], ([-1, -1], [2, 2]))
    before = metrics.neighbour_purity(sy.x, sy.phase, 3.5 * r)
    sim = Simulator(sy, SPHConfig(interfacial_tension={"a/b": 1.0}))
    for _ in range(25):
        sim.advance(0.02)
    mass = sy.rest_density
    p = (mass[:, None] * sy.v).sum(0)
    assert np.abs(p).max() < 1e-9 * (mass[:, None] * np.abs(sy.v)).sum()
    assert metrics.neighbour_purity(sy.x, sy.phase, 3.5 * r) > before + 0.05
