"""The network's wall input fills the diagonal gaps of lattice-sampled slanted walls
(NetConfig.wall_fill_gaps, dcdc.model.walls): slanted walls get particles between surface
particles that meet only diagonally; flat faces, a box's edges and deeper layers get none."""
import numpy as np
import torch

from dcdc.geometry import sample_walls
from dcdc.model.checkpoint import load_checkpoint, save_checkpoint, serve_checkpoint
from dcdc.model.networks import Scenes, build_network
from dcdc.model.walls import FilledWalls, fill_wall_gaps
from dcdc.neighbors import radius_search

R = 0.025
S = 2 * R


def _box(dim):
    """A closed box's walls, four lattice layers thick (the scenes' sampling)."""
    lo, hi = np.zeros(dim), np.ones(dim) * (0.6 if dim == 2 else 0.3)
    def sdf(x):  # > 0 inside the box's cavity, < 0 in its walls
        return np.min(np.concatenate([x - lo, hi - x], axis=1), axis=1)
    return sample_walls(sdf, lo - 4 * S, hi + 4 * S, S, 4 * S, anchor=np.full(dim, R))


def _slab(angle_deg):
    """A 2-D wall of thickness 2.2 s through the origin at ``angle_deg`` to the x axis, its
    upper face (normal n) facing the fluid; returns walls, normals, n."""
    a = np.radians(angle_deg)
    n = np.array([-np.sin(a), np.cos(a)])
    def sdf(x):  # distance outside the slab (> 0), negative inside
        return np.abs(x @ n + 1.1 * S) - 1.1 * S
    wx, wn = sample_walls(sdf, [-1, -1], [1, 1], S, 3 * S, anchor=[R, R])
    return wx, wn, n


def _largest_gap(wx, n, face_offset=0.0):
    """Largest distance from a point of the slab's upper face (|t| < 0.5) to the nearest
    wall particle."""
    t = np.linspace(-0.5, 0.5, 2001)
    along = np.array([n[1], -n[0]])
    pts = t[:, None] * along + face_offset * n
    d = np.min(np.linalg.norm(pts[:, None] - wx[None], axis=2), axis=1)
    return d.max()


def test_flat_walls_get_nothing():
    wx, wn = _box(2)
    assert len(fill_wall_gaps(wx, wn, S)[0]) == len(wx)
    # a 3-D floor: its surface particles meet diagonally too, but without a step in depth
    def floor(x):
        return x[:, 2]
    wx, wn = sample_walls(floor, [-0.3, -0.3, -0.3], [0.3, 0.3, 0.1], S, 4 * S, anchor=[R, R, R])
    assert len(fill_wall_gaps(wx, wn, S)[0]) == len(wx)
    wx, wn = _box(3)  # faces, edges and corners
    assert len(fill_wall_gaps(wx, wn, S)[0]) == len(wx)


def test_slanted_walls_are_closed_and_the_given_rows_kept():
    for angle in (30.0, 45.0, 63.0):
        wx, wn, n = _slab(angle)
        fx, fn = fill_wall_gaps(wx, wn, S)
        assert len(fx) > len(wx)
        np.testing.assert_array_equal(fx[:len(wx)], wx)
        np.testing.assert_array_equal(fn[:len(wx)], wn)
        added, added_n = fx[len(wx):], fn[len(wx):]
        # in the solid within one spacing of one of the slab's two faces (the surface layer
        # the wall particles are), facing out of that face
        h = added @ n
        upper = (h <= 1e-9) & (h > -S)
        lower = (h < -1.2 * S) & (h >= -2.2 * S)
        assert np.all(upper | lower) and upper.any() and lower.any()
        assert np.all(added_n[upper] @ n > 0.7) and np.all(added_n[lower] @ n < -0.7)
        np.testing.assert_allclose(np.linalg.norm(added_n, axis=1), 1.0, atol=1e-12)
        # the gap a particle slips through shrinks
        before, after = _largest_gap(wx, n), _largest_gap(fx, n)
        assert after < 0.9 * before, (angle, before, after)
        # never two particles on one point
        assert radius_search(fx, 0.2 * S, exclude_self=True).n_edges == 0


def test_filled_walls_per_scene_follow_the_offsets():
    a, an, _ = _slab(30.0)
    b, bn = _box(2)
    wx, wn = np.concatenate([a, b]), np.concatenate([an, bn])
    cache = FilledWalls()
    fx, fn, offs = cache.get(wx, wn, S, np.array([0, len(a), len(a) + len(b)]))
    fa, _ = fill_wall_gaps(a, an, S)
    assert offs.tolist() == [0, len(fa), len(fa) + len(b)]
    np.testing.assert_array_equal(fx[:len(fa)], fa)
    np.testing.assert_array_equal(fx[len(fa):], b)
    assert cache.get(wx, wn, S, np.array([0, len(a), len(a) + len(b)]))[0] is fx  # cached


def test_the_network_sees_the_filled_walls_only_when_told(tmp_path):
    torch.manual_seed(0)
    wx, wn, n = _slab(30.0)
    along = np.array([n[1], -n[0]])
    x = torch.tensor(np.array([0.3 * R * n + k * 0.07 * along for k in range(-3, 4)]))
    v = torch.zeros_like(x)
    rho = torch.full((len(x),), 1000.0, dtype=torch.float64)
    net = build_network("dcdc", 2).double()
    fx, fn = fill_wall_gaps(wx, wn, S)
    plain = net(x, v, rho, torch.as_tensor(wx), torch.as_tensor(wn))
    prefilled = net(x, v, rho, torch.as_tensor(fx), torch.as_tensor(fn))
    assert not torch.allclose(plain, prefilled, atol=1e-9)
    net.cfg.wall_fill_gaps = True
    filled = net(x, v, rho, torch.as_tensor(wx), torch.as_tensor(wn))
    assert torch.allclose(filled, prefilled, atol=1e-12)
    # the same in a batch of two scenes
    two = Scenes.from_counts([len(x), len(x)], [len(wx), len(wx)])
    out = net(torch.cat([x, x]), torch.cat([v, v]), torch.cat([rho, rho]),
              torch.as_tensor(np.concatenate([wx, wx])), torch.as_tensor(np.concatenate([wn, wn])),
              scenes=two)
    assert torch.allclose(out, torch.cat([prefilled, prefilled]), atol=1e-12)
    # how a checkpoint is served: the option travels with it, the weights do not change
    p, q = tmp_path / "a.pt", tmp_path / "b.pt"
    net.cfg.wall_fill_gaps = False
    save_checkpoint(p, net)
    assert load_checkpoint(p)[0].cfg.wall_fill_gaps is False
    serve_checkpoint(p, q, wall_fill_gaps=True)
    served = load_checkpoint(q)[0].double()
    assert served.cfg.wall_fill_gaps is True
    assert torch.allclose(served(x, v, rho, torch.as_tensor(wx), torch.as_tensor(wn)), prefilled,
                          atol=1e-12)
