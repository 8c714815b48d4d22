"""The wall conv leaves out the far face of a thin wall (NetConfig.wall_far_faces = False):
the far face of a thin wall is left out, solid walls are untouched."""
import numpy as np
import torch

from dcdc.model.networks import build_network, facing_walls
from dcdc.neighbors import radius_search

R = 0.025


def _thin_wall():
    """A vertical wall two particles thick at x = 0 / 0.05: the inner face (x = 0) faces
    the fluid on the left (normals −x), the outer face (x = 0.05) faces right (+x)."""
    ys = np.arange(-10, 11) * 2 * R
    inner = np.stack([np.zeros_like(ys), ys], 1)
    outer = np.stack([np.full_like(ys, 2 * R), ys], 1)
    normals = np.concatenate([np.tile([-1.0, 0.0], (len(ys), 1)), np.tile([1.0, 0.0], (len(ys), 1))])
    return np.concatenate([inner, outer]), normals


def test_far_face_of_a_thin_wall_is_left_out():
    wall, normals = _thin_wall()
    x = np.array([[-0.05, 0.0], [0.01, 0.0]])  # in front of the inner face; 1 cm past it
    nb = radius_search(x, 4.5 * R, wall)
    kept = facing_walls(nb, x, wall, normals, R)
    for i in range(2):
        seen = kept.index[kept.row_splits[i]:kept.row_splits[i + 1]]
        assert len(seen) and (wall[seen, 0] == 0.0).all()  # the inner face only
        allx = nb.index[nb.row_splits[i]:nb.row_splits[i + 1]]
        assert (wall[allx, 0] > 0).any()  # the search itself found the outer face


def test_solid_walls_keep_every_neighbour():
    # a floor four layers thick, every normal up: nothing lies behind a particle above it
    xs = np.arange(-10, 11) * 2 * R
    wall = np.array([(a, -k * 2 * R) for a in xs for k in range(4)])
    normals = np.tile([0.0, 1.0], (len(wall), 1))
    x = np.array([[0.0, 0.05], [0.1, 0.02], [0.2, -0.01]])
    nb = radius_search(x, 4.5 * R, wall)
    kept = facing_walls(nb, x, wall, normals, R)
    assert np.array_equal(kept.row_splits, nb.row_splits) and np.array_equal(kept.index, nb.index)


def test_the_network_ignores_the_far_face_unless_told():
    torch.manual_seed(0)
    wall, normals = _thin_wall()
    x = torch.tensor([[-0.05, 0.0], [-0.1, 0.05], [-0.05, 0.1]], dtype=torch.float64)
    v = torch.zeros_like(x)
    rho = torch.full((3,), 1000.0, dtype=torch.float64)
    net = build_network("dcdc", 2).double()
    inner = wall[:, 0] == 0.0
    both = net(x, v, rho, torch.as_tensor(wall), torch.as_tensor(normals))
    only_inner = net(x, v, rho, torch.as_tensor(wall[inner]), torch.as_tensor(normals[inner]))
    assert torch.allclose(both, only_inner, atol=1e-12)
    net.cfg.wall_far_faces = True
    seen_all = net(x, v, rho, torch.as_tensor(wall), torch.as_tensor(normals))
    assert not torch.allclose(seen_all, only_inner, atol=1e-9)


def test_a_particle_inside_a_solid_wall_still_sees_every_layer():
    # 1.5 r into a floor four layers thick: behind the top layer, but every layer faces up
    xs = np.arange(-10, 11) * 2 * R
    wall = np.array([(a, -k * 2 * R) for a in xs for k in range(4)])
    normals = np.tile([0.0, 1.0], (len(wall), 1))
    x = np.array([[0.0, -1.5 * R]])
    nb = radius_search(x, 4.5 * R, wall)
    kept = facing_walls(nb, x, wall, normals, R)
    assert kept.n_edges == nb.n_edges


def test_checkpoints_without_the_option_keep_seeing_every_wall_particle(tmp_path):
    from dcdc.model.checkpoint import digest, load_checkpoint, save_checkpoint
    net = build_network("dcdc", 2)
    assert net.cfg.wall_far_faces is False  # a new network leaves the far faces out
    p = tmp_path / "n.pt"
    save_checkpoint(p, net)
    assert load_checkpoint(p)[0].cfg.wall_far_faces is False
    ck = torch.load(p, weights_only=False)  # a file written before the option existed
    del ck["config"]["wall_far_faces"]
    ck["digest"] = digest(ck)
    torch.save(ck, p)
    assert load_checkpoint(p)[0].cfg.wall_far_faces is True
