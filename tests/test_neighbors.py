import numpy as np
import pytest
from scipy.spatial import cKDTree

from dcdc.errors import DcdcError
from dcdc.neighbors import radius_search


def _pairs(nb):
    return set(zip(nb.receivers().tolist(), nb.index.tolist()))


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_self_search_matches_kdtree(dim, dtype):
    rng = np.random.default_rng(dim)
    x = rng.uniform(-1, 1, (3000, dim)).astype(dtype)
    r = 0.13 if dim == 2 else 0.3
    nb = radius_search(x, r, exclude_self=True)
    tree = cKDTree(x.astype(np.float64))
    ref = {(i, j) for i, js in enumerate(tree.query_ball_point(x.astype(np.float64), r)) for j in js if i != j}
    got = _pairs(nb)
    # float32 boundary cases may differ only for pairs at |d - r| < 1e-6
    diff = got ^ ref
    d = [abs(np.linalg.norm(x[i].astype(np.float64) - x[j]) - r) for i, j in diff]
    assert all(v < 1e-5 for v in d)
    assert len(got) > 10 * len(x)


def test_cross_search_and_self_included():
    rng = np.random.default_rng(0)
    p = rng.uniform(0, 1, (500, 3))
    q = rng.uniform(-0.5, 1.5, (300, 3))
    nb = radius_search(q, 0.2, points=p)
    tree = cKDTree(p)
    ref = {(i, j) for i, js in enumerate(tree.query_ball_point(q, 0.2)) for j in js}
    assert _pairs(nb) == ref
    selfnb = radius_search(p, 0.2)
    assert all((i, i) in _pairs(selfnb) for i in range(len(p)))


def test_huge_domain_sparse_points():
    # two clusters 1 km apart: the grid must not allocate a cell per 0.1 m
    x = np.array([[0, 0, 0], [0.05, 0, 0], [1000, 0, 0], [1000.05, 0.0, 0]])
    nb = radius_search(x, 0.1, exclude_self=True)
    assert _pairs(nb) == {(0, 1), (1, 0), (2, 3), (3, 2)}


def test_bad_input():
    with pytest.raises(DcdcError):
        radius_search(np.full((3, 3), np.nan), 0.1)
    with pytest.raises(DcdcError):
        radius_search(np.zeros((3, 4)), 0.1)
    with pytest.raises(DcdcError):
        radius_search(np.zeros((3, 3)), -1.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_cell_grid_built_once_serves_moving_queries(dim):
    """A grid of static points (the SPH walls) searched by queries that move, inside and far
    outside its box, gives what a fresh search gives."""
    from dcdc.neighbors import CellGrid
    rng = np.random.default_rng(1)
    walls = rng.uniform(0, 1, (800, dim))
    grid = CellGrid(walls, 0.15)
    q = rng.uniform(-0.3, 1.3, (400, dim))
    for step in range(3):
        q = q + rng.normal(0, 0.2, q.shape)
        q[0] = 50.0  # far outside: clamped to a border cell, finds nothing
        got = _pairs(grid.search(q))
        assert got == _pairs(radius_search(q, 0.15, points=walls))
        tree = cKDTree(walls)
        assert got == {(i, j) for i, js in enumerate(tree.query_ball_point(q, 0.15)) for j in js}
    assert CellGrid(np.zeros((0, dim)), 0.1).search(q).n_edges == 0


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_one_pass_search_equals_two_pass_search(dim, dtype):
    """``capacity`` (the network's one-pass search) gives the identical CSR list,
    order included, whether the bound holds or a query overflows it (two-pass fallback)."""
    from dcdc.neighbors import CellGrid

    rng = np.random.default_rng(dim + 10)
    x = rng.uniform(0, 1, (2000, dim)).astype(dtype)
    x[:50] = x[0]  # a clump: one query with far more neighbours than the rest
    walls = rng.uniform(0, 1, (300, dim)).astype(dtype)
    for pts, queries, excl in ((x, None, True), (x, None, False), (walls, x, False)):
        grid = CellGrid(pts, 0.1)
        ref = grid.search(queries, excl)
        for cap in (1, 30, 1000):
            nb = grid.search(queries, excl, capacity=cap)
            np.testing.assert_array_equal(nb.row_splits, ref.row_splits)
            np.testing.assert_array_equal(nb.index, ref.index)
    nb = radius_search(x, 0.1, walls, capacity=8)
    ref = radius_search(x, 0.1, walls)
    np.testing.assert_array_equal(nb.index, ref.index)
