import numpy as np
import pytest
import trimesh

from dcdc.geometry import lattice, sample_walls
from dcdc.geometry import shapes as sh

rng = np.random.default_rng(0)


def test_sphere_and_cylinder_exact():
    p = rng.uniform(-1, 1, (500, 3))
    assert np.allclose(sh.sphere([0, 0, 0], 0.4)(p), np.linalg.norm(p, axis=1) - 0.4)
    f = sh.cylinder([0, 0, 0], 0.3, 1.0, axis=1)
    inside = (np.linalg.norm(p[:, [0, 2]], axis=1) < 0.3) & (np.abs(p[:, 1]) < 0.5)
    assert np.array_equal(f(p) < 0, inside)
    # 2-D cross-section of a vertical cylinder is a rectangle
    q = p[:, :2]
    assert np.array_equal(f(q) < 0, (np.abs(q[:, 0]) < 0.3) & (np.abs(q[:, 1]) < 0.5))


def test_revolved_shell_2d_is_section_of_3d():
    wall, bowl = sh.glass_profile([[0, 0], [0.3, 0.05], [0.5, 0.4], [0.55, 0.8]], 0.3, 0.3)
    f = sh.revolved_shell(wall, 0.1)
    p2 = rng.uniform(-0.8, 0.8, (400, 2)) + [0, 0.6]
    p3 = np.c_[p2, np.zeros(len(p2))]
    assert np.allclose(f(p2), f(p3))
    # rotating about the axis does not change the 3-D distance
    a = 0.7
    rot = np.c_[p3[:, 0] * np.cos(a), p3[:, 1], p3[:, 0] * np.sin(a)]
    assert np.allclose(f(p3), f(rot))
    inside = sh.profile_interior(bowl)
    assert inside(np.array([[0.0, 0.6]]))[0] and not inside(np.array([[0.0, 0.1]]))[0]


def test_hourglass_neck_is_narrow():
    prof = sh.hourglass_profile(0.5, 1.8, 0.12, 0.4)
    inside = sh.profile_interior(prof)
    assert inside(np.array([[0.1, 0.9]]))[0]          # in the neck
    assert not inside(np.array([[0.2, 0.9]]))[0]      # beside the neck
    assert inside(np.array([[0.4, 0.2]]))[0] and inside(np.array([[0.4, 1.6]]))[0]


def test_terrain_slopes_down_and_has_basins():
    h = sh.terrain_height([0, 0], [4, 1.6], base=0.8, slope=0.12, seed=1)
    x = np.linspace(0, 4, 200)
    z = np.full_like(x, 0.8)
    assert h(x[:10], z[:10]).mean() > h(x[-10:], z[-10:]).mean() + 0.3
    flat = sh.terrain_height([0, 0], [4, 1.6], base=0.8, slope=0.12, seed=1, channels=0,
                             depressions=0, roughness=0)
    assert np.allclose(flat(x, z), 0.8 - 0.12 * x)
    X, Z = np.meshgrid(np.linspace(0, 4, 80), np.linspace(0, 1.6, 40))
    assert (h(X, Z) - flat(X, Z)).min() < -0.1  # channels and depressions cut into the plane
    f = sh.heightfield(h)
    pts = np.c_[X.ravel(), h(X, Z).ravel() + 0.05, Z.ravel()]
    assert (f(pts) > 0).all()


def test_mesh_sdf_matches_sphere_and_section():
    m = trimesh.creation.icosphere(subdivisions=3, radius=0.3)
    f = sh.mesh_solid(m)
    p = rng.uniform(-0.4, 0.4, (300, 3))
    assert np.abs(f(p) - (np.linalg.norm(p, axis=1) - 0.3)).max() < 0.01
    g = sh.mesh_section(m, 0.0)
    assert np.abs(g(p[:, :2]) - (np.linalg.norm(p[:, :2], axis=1) - 0.3)).max() < 0.01


def test_walls_sampled_from_union_have_inward_normals():
    f = sh.union(sh.container([0, 0], [1, 1]), sh.sphere([0.5, 0.3], 0.15))
    x, n = sample_walls(f, [-0.2, -0.2], [1.2, 1.2], 0.05, 0.1, anchor=[0.025, 0.025])
    floor = (x[:, 1] < 0) & (x[:, 0] > 0.1) & (x[:, 0] < 0.9)
    assert floor.any() and np.allclose(n[floor], [0, 1], atol=1e-6)
    ball = np.linalg.norm(x - [0.5, 0.3], axis=1) < 0.16
    assert ball.any()
    radial = (x[ball] - [0.5, 0.3]) / np.linalg.norm(x[ball] - [0.5, 0.3], axis=1, keepdims=True)
    assert ((n[ball] * radial).sum(1) > 0.9).all()


def test_no_wall_particles_buried_where_solids_overlap():
    # a block sunk into the floor of a tank: min() of the two distance functions makes the
    # floor under the block look shallow; with the fluid box, only particles that a fluid
    # lattice point can see (within thickness + spacing·√2) stay
    from scipy.spatial import cKDTree

    s, t, anchor = 0.05, 0.1, [0.025, 0.025]
    tank = sh.container([0.0, 0.0], [1.0, 1.0], open_top=False)
    block = sh.box([0.3, -0.1], [0.7, 0.3])
    union = lambda q: np.minimum(tank(q), block(q))  # noqa: E731
    lo, hi = [-0.15, -0.15], [1.15, 1.15]
    x_all, _ = sample_walls(union, lo, hi, s, t, anchor)
    x, n = sample_walls(union, lo, hi, s, t, anchor, fluid_box=([0, 0], [1, 1]))
    g = lattice([0, 0], [1, 1], s / 4)
    d, _ = cKDTree(g[union(g) > 0]).query(x_all)  # true distance to the fluid space
    assert len(x) < len(x_all)
    kept = {tuple(p) for p in np.round(x, 6)}
    dropped = np.array([tuple(p) not in kept for p in np.round(x_all, 6)])
    assert d[dropped].min() > t  # only particles deeper than the shell go
    d_kept, _ = cKDTree(g[union(g) > 0]).query(x)
    assert (d_kept <= t + s * np.sqrt(2) + 1e-9).all()
    # without overlaps nothing changes
    a, _ = sample_walls(tank, lo, hi, s, t, anchor)
    b, _ = sample_walls(tank, lo, hi, s, t, anchor, fluid_box=([0, 0], [1, 1]))
    assert np.array_equal(a, b)
