"""The phase term of the training loss (dcdc/train/loss.py): the error of each phase's centre
of mass, per scene. A drift shared by a phase counts in full; independent errors of the same
size per particle largely cancel; phases and scenes are kept apart."""
import numpy as np
import pytest
import torch

from dcdc.errors import DcdcError
from dcdc.model.networks import build_network
from dcdc.train.config import LossConfig, load_config
from dcdc.train.loss import EPS, phase_error, phase_groups, unrolled_loss
from dcdc.train.sampler import collate


def _scene(n, densities, seed=0, shift=0.0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 1, size=(n, 2)) + shift
    return {"position": np.stack([x, x]), "velocity": np.zeros_like(x),
            "density": np.asarray(densities, float), "wall_position": np.zeros((0, 2)),
            "wall_normal": np.zeros((0, 2)), "gravity": np.array([0.0, -9.81])}


def test_groups_are_scene_and_density():
    a = _scene(4, [1000, 1000, 1100, 1100])
    b = _scene(3, [1000, 1000, 1000], seed=1, shift=5.0)
    batch = collate([a, b], dtype=torch.float64)
    group, n = phase_groups(batch)
    g = group.numpy()
    assert n == 3
    assert g[0] == g[1] != g[2] == g[3]
    assert len({g[4], g[5], g[6]}) == 1 and g[4] not in (g[0], g[2])


def test_a_shared_drift_counts_and_independent_errors_cancel():
    n = 1000
    batch = collate([_scene(n, [1000] * (n // 2) + [1100] * (n // 2))], dtype=torch.float64)
    groups = phase_groups(batch)
    target = batch.position[1]
    drift = target.clone()
    drift[n // 2:, 1] += 1e-3  # the heavy phase 1 mm off, every particle
    rng = np.random.default_rng(2)
    noise = target + torch.as_tensor(rng.normal(size=(n, 2)) * 1e-3 / np.sqrt(2))
    got = float(phase_error(drift, target, groups, 0.5))
    want = 0.5 * ((1e-6 + EPS) ** 0.25 + EPS ** 0.25)  # one phase off by 1 mm, one exact
    assert got == pytest.approx(want, rel=1e-9)
    # the same 1 mm per particle, independent: its phase means are ~1 mm/√500
    assert float(phase_error(noise, target, groups, 0.5)) < 0.5 * got


def test_phase_weight_adds_the_term_and_its_gradient_moves_the_phase():
    torch.manual_seed(0)
    net = build_network("dcdc", 2).double()
    batch = collate([_scene(40, [1000] * 20 + [1500] * 20)], dtype=torch.float64)
    base, _ = unrolled_loss(net, batch, LossConfig(unroll=1, neighbor_scale=0.0))
    more, _ = unrolled_loss(net, batch, LossConfig(unroll=1, neighbor_scale=0.0, phase_weight=1.0))
    assert float(more.detach()) > float(base.detach())
    x = batch.position[1].clone().requires_grad_(True)
    shifted = x.detach().clone()
    shifted[:20, 1] -= 1e-3  # target: the light phase 1 mm lower
    phase_error(x, shifted, phase_groups(batch), 0.5).backward()
    g = x.grad.numpy()
    assert (g[:20, 1] > 0).all() and np.allclose(g[:20, 1], g[0, 1])  # descend: down, together
    assert np.allclose(g[20:], 0, atol=1e-6) and np.allclose(g[:, 0], 0)


def test_phase_weight_is_checked():
    with pytest.raises(DcdcError, match="loss.phase_weight"):
        load_config(None, ["loss.phase_weight=-1"])
