"""dcdc.metrics: every metric against a hand-computed value on tiny arrays."""
import numpy as np
import pytest

from dcdc import metrics as M


def _layers(n=10):
    """Two phases on a 2-D lattice: phase 1 (heavy) in y < 0.5, phase 0 above."""
    g = (np.arange(n) + 0.5) / n
    x = np.array([(a, b) for a in g for b in g])
    phase = (x[:, 1] < 0.5).astype(int)
    return x, phase


def test_phase_heights_mean_median_and_empty_phase():
    x = np.array([[0, 0.0], [0, 1.0], [0, 5.0], [0, 2.0]])
    phase = np.array([0, 0, 0, 1])
    h = M.phase_heights(x, phase, 3)
    assert h[0] == pytest.approx(2.0) and h[1] == pytest.approx(2.0) and np.isnan(h[2])
    assert M.phase_heights(x, phase, 2, stat="median")[0] == pytest.approx(1.0)
    active = np.array([True, True, False, True])
    assert M.phase_heights(x, phase, 2, active=active)[0] == pytest.approx(0.5)


def test_order_checks():
    x, phase = _layers()
    assert M.phase_order_ok(x, phase, [1, 0])
    assert not M.phase_order_ok(x, phase, [0, 1])
    rho = [1000.0, 3000.0]
    assert M.density_order_ok(x, phase, rho)
    assert not M.density_order_ok(x, phase, rho[::-1])
    # equal densities are not compared; an empty phase is skipped
    assert M.density_order_ok(x, phase, [1000.0, 1000.0])
    assert M.density_order_ok(x, phase, [1000.0, 3000.0, 5000.0])
    # three phases, two of equal density: the heavy one must lie below both
    x3 = np.array([[0, 1.0], [0, 2.0], [0, 3.0]])
    assert M.density_order_ok(x3, [0, 1, 2], [3000.0, 1000.0, 1000.0])
    assert not M.density_order_ok(x3, [1, 0, 2], [3000.0, 1000.0, 1000.0])
    assert not M.density_order_ok(x3, [1, 2, 0], [3000.0, 1000.0, 1000.0])
    assert not M.density_order_ok(x3, [2, 0, 1], [3000.0, 1000.0, 1000.0])  # one light below


def test_ideal_layer_purity_matches_hand_count():
    # 4 particles of phase 1 should fill [0, 0.4) and 4 of phase 0 [0.4, 0.8) (area 1, V 0.1)
    y = np.array([0.05, 0.15, 0.25, 0.35, 0.45, 0.55, 0.65, 1.5])
    phase = np.array([1, 1, 1, 1, 0, 0, 0, 0])
    x = np.c_[np.zeros(8), y]
    p = M.ideal_layer_purity(x, phase, [1, 0], floor=0.0, area=1.0, volume=0.1, spacing=0.05)
    assert p == pytest.approx(7 / 8)
    # reversed order: phase 0 expected in [0, 0.4] ± 0.05, phase 1 in [0.4, 0.8] ± 0.05
    p2 = M.ideal_layer_purity(x, phase, [0, 1], 0.0, 1.0, 0.1, 0.05)
    assert p2 == pytest.approx(1 / 8)  # only the phase-1 particle at 0.35 (>= 0.35)


def test_ideal_layer_purity_same_as_sph_validation():
    """The validation's definition (dcdc.sph.measures.layer_purity) gives the same number."""
    measures = pytest.importorskip("dcdc.sph.measures")
    from dcdc.particles import ParticleSystem, Phase
    rng = np.random.default_rng(1)
    x = rng.random((200, 2))
    phase = (rng.random(200) < 0.4).astype(int)
    sy = ParticleSystem(2, 0.025, x, np.zeros_like(x), phase,
                        [Phase("a", 1000.0), Phase("b", 2000.0)], np.zeros((0, 2)),
                        np.zeros((0, 2)), (0, -9.81), ((-1, -1), (2, 2)))
    ours = M.ideal_layer_purity(x, phase, [1, 0], 0.0, 1.0, 0.0025, sy.spacing)
    assert ours == pytest.approx(measures.layer_purity(sy, [1, 0], 0.0, 1.0, 0.0025))


def test_neighbour_purity():
    x, phase = _layers(10)
    p = M.neighbour_purity(x, phase, radius=0.11)  # 4-neighbourhood on the 0.1 lattice
    # 100 particles; the 20 next to the interface have 1 foreign neighbour of 4 (of 3 at
    # the left/right border), the other 80 none
    assert p == pytest.approx((80 + 16 * 3 / 4 + 4 * 2 / 3) / 100)
    assert M.neighbour_purity(x, np.zeros(len(x), int), 0.11) == pytest.approx(1.0)
    checker = ((np.round(x[:, 0] * 10 - 0.5) + np.round(x[:, 1] * 10 - 0.5)) % 2).astype(int)
    assert M.neighbour_purity(x, checker, 0.11) == pytest.approx(0.0)


def test_phase_volumes_and_errors():
    psi = np.array([1.0, 2.0, 0.5, np.nan])
    phase = np.array([0, 0, 1, 1])
    v = M.phase_volumes(psi, phase, 0.1, 3)
    assert v == pytest.approx([0.1 + 0.05, 0.1, 0.0])
    err = M.volume_error(v, [0.2, 0.1, 0.0])
    assert err[0] == pytest.approx(-0.25) and err[1] == pytest.approx(0.0) and np.isnan(err[2])
    assert M.density_error(psi) == pytest.approx((0 + 1 + 0) / 3)


def test_energy_and_momentum():
    v = np.array([[1.0, 0.0], [0.0, -2.0]])
    m = np.array([2.0, 1.0])
    assert M.kinetic_energy(v, m) == pytest.approx(0.5 * (2 * 1 + 1 * 4))
    assert M.momentum(v, m) == pytest.approx([2.0, -2.0])


def test_position_and_nearest_error():
    true = np.array([[0.0, 0.0], [1.0, 0.0]])
    pred = true + np.array([[0.0, 0.3], [0.4, 0.0]])
    assert M.position_error(pred, true) == pytest.approx(0.35)
    # identity-free: swapping predicted particles changes nothing
    assert M.nearest_error(pred[::-1], true) == pytest.approx(0.35)
    assert M.nearest_error(true[::-1], true) == pytest.approx(0.0)
    assert np.isnan(M.position_error(np.full((2, 2), np.nan), true))


@pytest.mark.slow
@pytest.mark.parametrize("n", [100, 1000, 10_000])
def test_wasserstein_distance_of_a_shifted_cloud_is_the_shift(n):
    rng = np.random.default_rng(0)
    a = rng.random((n, 3))
    assert M.wasserstein_distance(a, a) == pytest.approx(0.0, abs=1e-6)
    assert M.wasserstein_distance(a, a + [0.1, 0.0, 0.0]) == pytest.approx(0.1, rel=1e-6)
    assert M.wasserstein_distance(a, a + [2.0, 0.5, 0.0]) == pytest.approx(np.hypot(2.0, 0.5),
                                                                           rel=1e-6)


def test_wasserstein_distance_ignores_identities_and_sees_unequal_clouds():
    rng = np.random.default_rng(1)
    a = rng.random((300, 2))
    assert M.wasserstein_distance(a[::-1], a) == pytest.approx(0.0, abs=1e-6)
    # half the cloud moved 0.2 m up: W2 = sqrt(½ · 0.2²) at most, well above 0
    b = a.copy()
    b[:150, 1] += 0.2
    d = M.wasserstein_distance(a, b)
    assert 0.02 < d <= np.sqrt(0.5) * 0.2 + 1e-9
    assert np.isnan(M.wasserstein_distance(a, a[:0]))
    assert np.isnan(M.wasserstein_distance(a, np.full((3, 2), np.nan)))


def _box_layers(rng, n=400, mixed=False):
    """Two phases in a 1 m wide box: heavy (phase 1) in the lower half, light (0) above;
    ``mixed``: the phases drawn at random over the whole column (same counts)."""
    x = np.stack([rng.random(n), rng.random(n)], axis=1)
    phase = (x[:, 1] < 0.5).astype(int)
    if mixed:
        phase = rng.permutation(phase)
    return x, phase


def test_height_distance_and_purity_tell_a_mixed_column_from_layers():
    rng = np.random.default_rng(2)
    clean, ph = _box_layers(rng)
    clean2, ph2 = _box_layers(np.random.default_rng(3))
    mixed, phm = _box_layers(np.random.default_rng(4), mixed=True)
    depth = M.column_depth(clean)
    same = M.height_distance(clean2, ph2, clean, ph, 2)
    apart = M.height_distance(mixed, phm, clean, ph, 2)
    assert (same < 0.05 * depth).all()
    # a phase spread over the column instead of its half: W1 = 1/4 of the column
    assert apart == pytest.approx([0.25, 0.25], abs=0.04)
    pur_clean = M.neighbour_purity_per_phase(clean, ph, 0.1, 2)
    pur_mixed = M.neighbour_purity_per_phase(mixed, phm, 0.1, 2)
    assert (pur_clean > 0.8).all() and (np.abs(pur_mixed - 0.5) < 0.1).all()
    assert M.layers_like(M.neighbour_purity_per_phase(clean2, ph2, 0.1, 2), pur_clean, same, depth)
    assert not M.layers_like(pur_mixed, pur_clean, apart, depth)
    # each criterion alone fails the verdict
    assert not M.layers_like(pur_mixed, pur_clean, same, depth)
    assert not M.layers_like(pur_clean, pur_clean, apart, depth)
    # a layer shifted by more than 5 % of the column fails on heights alone
    shifted = M.height_distance(clean + [0.0, 0.08], ph, clean, ph, 2)
    assert shifted == pytest.approx([0.08, 0.08])
    assert not M.layers_like(pur_clean, pur_clean, shifted, depth)
    assert not M.layers_like([np.nan], [np.nan], [np.nan], depth)


def test_wall_penetrations():
    # a floor of wall particles at y = 0 (normals up) and 2 layers below
    xs = np.arange(-10, 11) * 0.05
    wall = np.array([(a, -k * 0.05) for a in xs for k in range(3)])
    normals = np.tile([0.0, 1.0], (len(wall), 1))
    # on the lattice one spacing up, far above, between the first two layers (nearest to the
    # second), among the lower layers, touching a wall particle from the fluid's side
    fluid = np.array([[0.0, 0.05], [0.1, 0.2], [0.02, -0.03], [0.2, -0.07], [0.0, 0.005]])
    mask = M.inside_walls(fluid, wall, normals, spacing=0.05)
    assert mask.tolist() == [False, False, True, True, False]
    assert M.wall_penetrations(fluid, wall, normals, 0.05) == 2
    assert M.wall_penetrations(fluid, wall[:0], normals[:0], 0.05) == 0
    # the walls' cell list built once gives the same answer, also for clouds far outside it
    grid = M.wall_grid(wall, 0.05)
    assert M.inside_walls(fluid, wall, normals, 0.05, grid=grid).tolist() == mask.tolist()
    rng = np.random.default_rng(0)
    cloud = rng.uniform([-0.6, -0.3], [0.6, 0.4], size=(500, 2))
    assert (M.inside_walls(cloud, wall, normals, 0.05, grid=grid)
            == M.inside_walls(cloud, wall, normals, 0.05)).all()
    assert M.inside_walls(cloud + 5.0, wall, normals, 0.05, grid=grid).sum() == 0


def test_convex_corner_is_not_a_penetration():
    # the rim of a wall one particle thick: its top (normals up) and its left face (normals
    # left); a particle beside the face, just below the top, lies behind the top's plane
    top = np.array([[0.0, 0.0], [0.05, 0.0]])
    face = np.array([[0.0, -k * 0.05] for k in range(1, 6)])
    wall = np.concatenate([top, face])
    normals = np.concatenate([np.tile([0.0, 1.0], (2, 1)), np.tile([-1.0, 0.0], (5, 1))])
    beside = np.array([[-0.045, -0.03]])  # in front of the face, 0.03 below the top's plane
    assert not M.inside_walls(beside, wall, normals, 0.05).any()
    through = np.array([[0.03, -0.03]])  # behind the face and below the top: inside
    assert M.inside_walls(through, wall, normals, 0.05).all()


def test_shallow_convex_edge_is_not_a_penetration():
    """An hourglass's funnel (normals 38° from the neck's) meeting its vertical neck: a
    particle a radius in front of the funnel, just above the neck's top particle, lies more
    than r/2 behind that particle's plane and is still outside; one behind the funnel's face
    is inside."""
    neck = np.array([[0.0, -k * 0.05] for k in range(5)])
    funnel = np.array([[-0.05, 0.05], [-0.05, 0.1], [-0.1, 0.1], [-0.1, 0.15], [-0.15, 0.15]])
    nf = np.array([0.78, 0.62]) / np.hypot(0.78, 0.62)
    wall = np.concatenate([neck, funnel])
    normals = np.concatenate([np.tile([1.0, 0.0], (5, 1)), np.tile(nf, (5, 1))])
    above = np.array([[-0.014, 0.04]])  # 0.022 in front of the funnel, 0.014 behind x = 0
    assert (above - neck[0]) @ [1.0, 0.0] < -0.0125 and (above - funnel[0]) @ nf > 0.02
    assert not M.inside_walls(above, wall, normals, 0.05).any()
    behind = np.array([[-0.06, 0.03]])  # 0.02 behind the funnel's face
    assert M.inside_walls(behind, wall, normals, 0.05).all()


def _basin(r=0.025):
    """A 2-D V-shaped basin of wall particles (slopes ±0.5) with fluid rows filling it to
    6 rows above its lowest point; returns (fluid x, wall x, row index of each particle)."""
    s = 2 * r
    xs = np.arange(-1.0, 1.0 + 1e-9, s)
    wall = np.stack([xs, 0.5 * np.abs(xs)], 1)
    pts, rows = [], []
    for k in range(6):
        y = 2 * r + k * s
        for x in xs:
            if 0.5 * abs(x) + 2 * r <= y + 1e-9:
                pts.append((x, y))
                rows.append(k)
    return np.array(pts), wall, np.array(rows)


def test_pooled_heavy_on_a_basin():
    """Heavy in the bottom rows of a basin: all pooled, none inverted; the same rows with
    the phases swapped: the light rows under the heavy ones count as inverted; heavy as a
    thin film running down a slope (one row, no fluid above): not pooled."""
    r = 0.025
    x, wall, rows = _basin(r)
    dens = [1000.0, 3000.0]
    heavy_low = np.where(rows < 2, 1, 0)
    pooled, inverted = M.pooled_heavy(x, heavy_low, dens, wall, r)
    assert pooled == 1.0 and inverted == 0.0
    _, inverted = M.pooled_heavy(x, 1 - heavy_low, dens, wall, r)
    assert inverted > 0.3
    film = np.stack([np.linspace(0.3, 0.9, 13), 0.5 * np.linspace(0.3, 0.9, 13) + 2 * r], 1)
    ph = np.ones(len(film), dtype=int)
    pooled, _ = M.pooled_heavy(film, ph, dens, wall, r)
    assert pooled == 0.0


def test_layer_summary_sees_order_purity_and_light_fluid_held_at_walls():
    """A walled 2-D box, heavy (phase 0) under light (phase 1): right order, no phase held at
    the walls; one light particle swapped into the floor row is held (1 of the light phase),
    the heavy one swapped to the top of the light layer is not (denser than all around it);
    the layers inverted: wrong order, and nothing counted as held
    (a whole layer is not a particle held at the wall: mostly its own phase around it)."""
    from dcdc.metrics import layer_summary
    r = 0.01
    g = 2 * r * np.arange(20)
    x = np.stack(np.meshgrid(g + 2 * r, g + 2 * r), -1).reshape(-1, 2)  # 20 x 20 fluid
    walls = np.concatenate([np.c_[np.arange(-1, 23) * 2 * r, np.zeros(24)],
                            np.c_[np.zeros(22), np.arange(1, 23) * 2 * r],
                            np.c_[np.full(22, 42 * r), np.arange(1, 23) * 2 * r]])
    phase = (x[:, 1] > 0.2).astype(int)
    dens = [2000.0, 700.0]
    ok = layer_summary(x, phase, dens, walls, r)
    assert ok["order"] and np.all(ok["trapped"] == 0) and np.all(ok["purity"] > 0.8)
    swapped = phase.copy()
    floor = np.flatnonzero(np.isclose(x[:, 1], 2 * r) & np.isclose(x[:, 0], 0.2))
    top = np.flatnonzero(np.isclose(x[:, 1], 40 * r) & np.isclose(x[:, 0], 0.2))
    swapped[floor], swapped[top] = 1, 0
    held = layer_summary(x, swapped, dens, walls, r)
    assert held["order"]
    np.testing.assert_allclose(held["trapped"], [0.0, 1 / 200])
    bad = layer_summary(x, 1 - phase, dens, walls, r)
    assert not bad["order"] and np.all(bad["trapped"] == 0)
