"""The wall term of the training loss (dcdc/train/loss.py): zero for centres at the margin
in front of the walls, the documented formula behind it, its gradient pushing out, and
scene-aware (a particle is judged by its own scene's walls)."""
import numpy as np
import pytest
import torch

from dcdc.model.networks import build_network
from dcdc.train.config import LossConfig, load_config
from dcdc.errors import DcdcError
from dcdc.train.loss import EPS, unrolled_loss, wall_penalty
from dcdc.train.sampler import collate

R = 0.025


def _floor_scene(ys, shift=0.0):
    """Wall particles of a floor whose surface is y = 0 (one row at y = −r, normals up) and
    fluid particles at x = 0, heights ``ys``; the scene shifted by ``shift`` along x."""
    xs = np.arange(-20, 21) * 2 * R
    wall = np.stack([xs + shift, np.full_like(xs, -R)], axis=1)
    fluid = np.stack([np.full(len(ys), shift), np.asarray(ys, float)], axis=1)
    return {"position": np.stack([fluid, fluid]), "velocity": np.zeros_like(fluid),
            "density": np.full(len(ys), 1000.0), "wall_position": wall,
            "wall_normal": np.tile([0.0, 1.0], (len(xs), 1)), "gravity": np.array([0.0, -9.81])}


def _geometry(net, batch):
    return net.prepare(batch.position[0], batch.density, batch.wall_position, batch.scenes).wall


def test_wall_penalty_is_the_documented_hinge():
    net = build_network("dcdc", 2)
    ys = [2 * R, 0.5 * R, 0.25 * R, 0.0, -0.5 * R, 0.5]  # the last has no wall neighbour
    batch = collate([_floor_scene(ys)], dtype=torch.float64)
    x = batch.position[0].clone().requires_grad_(True)
    pen = wall_penalty(x, batch, _geometry(net, batch), R, 1.5, 0.5)
    s = np.asarray(ys) + R  # distance in front of the wall row
    depth = np.maximum(0.0, 1.5 * R - s)
    want = (depth ** 2 + EPS) ** 0.25 - EPS ** 0.25
    want[-1] = 0.0
    p = pen.detach().numpy()
    assert p == pytest.approx(want, abs=1e-12)
    assert p[0] == 0 and p[1] == pytest.approx(0.0, abs=1e-12) and p[4] > p[3] > p[2] > 0
    pen.sum().backward()
    gy = x.grad[:, 1].numpy()
    assert (gy[2:5] < 0).all()  # descending the loss moves them up, out of the wall
    assert gy[0] == 0 and gy[-1] == 0 and (x.grad[:, 0] == 0).all()


def test_wall_penalty_uses_each_scenes_own_walls():
    net = build_network("dcdc", 2)
    # scene 2 lies 10 m away; its particle sits 0.5 r behind its own floor's surface
    batch = collate([_floor_scene([2 * R]), _floor_scene([-0.5 * R], shift=10.0)],
                    dtype=torch.float64)
    pen = wall_penalty(batch.position[0], batch, _geometry(net, batch), R, 1.5, 0.5)
    assert pen[0] == 0 and pen[1] > 0


def test_wall_weight_adds_the_term_and_zero_leaves_the_loss_as_it_was():
    torch.manual_seed(0)
    net = build_network("dcdc", 2).double()
    batch = collate([_floor_scene([R, 0.0, 3 * R])], dtype=torch.float64)
    base, _ = unrolled_loss(net, batch, LossConfig(unroll=1, neighbor_scale=0.0))
    same, _ = unrolled_loss(net, batch, LossConfig(unroll=1, neighbor_scale=0.0, wall_weight=0.0))
    more, _ = unrolled_loss(net, batch, LossConfig(unroll=1, neighbor_scale=0.0, wall_weight=2.0,
                                                wall_margin=1.5))
    assert float(same.detach()) == float(base.detach())
    assert float(more.detach()) > float(base.detach())


@pytest.mark.parametrize("override, msg", [("loss.wall_weight=-1", "loss.wall_weight"),
                                           ("loss.wall_margin=9", "loss.wall_margin")])
def test_wall_options_are_checked(override, msg):
    with pytest.raises(DcdcError, match=msg):
        load_config(None, [override])
