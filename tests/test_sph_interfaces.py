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
    sim = Simulator(sy, SPHConfig(interfacial_tension={"a/b": 1.0}, interfacial_model="pairwise"))
    for _ in range(25):
        sim.advance(0.02)
    mass = sy.rest_density
    p = (mass[:, None] * sy.v).sum(0)
    assert np.abs(p).max() < 1e-9 * (mass[:, None] * np.abs(sy.v)).sum()
    assert metrics.neighbour_purity(sy.x, sy.phase, 3.5 * r) > before + 0.05


# ---------------------------------------------------------------------------- "csf" model
def _lattice_drop(dim, r=0.01, R=0.09):
    from dcdc.sph.neighbourhood import build
    s, h = 2 * r, 4 * r
    V0 = lattice_volume(s, h, dim)
    half = R + 3 * h
    ax = np.arange(-half, half, s) + s / 2
    x = np.stack(np.meshgrid(*([ax] * dim), indexing="ij"), -1).reshape(-1, dim)
    dist = np.linalg.norm(x, axis=1)
    phase = (dist < R).astype(np.int64)
    nbh = build(x, np.full((1, dim), 100.0), np.ones(1), h, V0)
    return x, dist, phase, nbh, h, V0


def _csf_force(x, phase, nbh, h, V0, sigma, dim):
    from dcdc.sph.interfaces import coefficients, csf_acceleration
    ph = [Phase("amb", 1000.0), Phase("drop", 700.0)]
    C = coefficients("csf", {"amb/drop": sigma}, ph, h, V0, dim)
    rho0 = np.array([1000.0, 700.0])[phase]
    a = csf_acceleration(phase, rho0, C, nbh.rs, nbh.idx, nbh.G, nbh.Sb, V0)
    return (rho0 * V0)[:, None] * a


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_csf_force_on_a_lattice_drop_is_young_laplace_and_linear_in_sigma(dim):
    """The capillary force summed over a drop cut from the rest lattice (both sides of the
    interface) is σκ per area of interface (measured 0.99 in 2-D), points inward, is zero in
    total (momentum) and scales with σ."""
    import math
    x, dist, phase, nbh, h, V0 = _lattice_drop(dim, R=0.09 if dim == 2 else 0.07)
    n = int(phase.sum())
    R = (n * V0 / math.pi) ** 0.5 if dim == 2 else (3 * n * V0 / (4 * math.pi)) ** (1 / 3)
    area = 2 * math.pi * R if dim == 2 else 4 * math.pi * R * R
    F1 = _csf_force(x, phase, nbh, h, V0, 1.0, dim)
    F2 = _csf_force(x, phase, nbh, h, V0, 2.0, dim)
    inward = -(F1 * x).sum(1) / np.maximum(dist, 1e-12)
    assert inward.sum() / area / ((dim - 1) / R) == pytest.approx(1.0, abs=0.05)
    assert np.abs(F1.sum(0)).max() < 1e-9 * np.abs(F1).sum()
    assert np.allclose(F2, 2 * F1, rtol=1e-12, atol=1e-15)


@pytest.mark.slow
def test_csf_conserves_momentum_in_a_moving_emulsion():
    """Two interleaved phases of unlike densities, no walls, no gravity: Σ m v stays 0."""
    from dcdc.geometry import fill_box
    from dcdc.particles import ParticleSystem
    r = 0.02
    x = fill_box([0, 0], [0.4, 0.4], 2 * r)
    phase = np.random.default_rng(1).integers(0, 2, len(x))
    sy = ParticleSystem(2, r, x, np.zeros_like(x), phase, [Phase("a", 1000.0), Phase("b", 500.0)],
                        np.zeros((0, 2)), np.zeros((0, 2)), [0, 0], ([-1, -1], [2, 2]))
    sim = Simulator(sy, SPHConfig(interfacial_tension={"a/b": 1.0}, interfacial_model="csf"))
    for _ in range(10):
        sim.advance(0.02)
    mass = sy.rest_density
    p = (mass[:, None] * sy.v).sum(0)
    assert np.abs(sy.v).max() > 0
    assert np.abs(p).max() < 1e-9 * (mass[:, None] * np.abs(sy.v)).sum()


def test_interfacial_model_is_a_solver_setting_and_a_bad_one_is_a_one_line_error():
    assert SPHConfig().interfacial_model == "curvature"
    assert SPHConfig.from_dict({"interfacial_model": "csf"}).interfacial_model == "csf"
    with pytest.raises(DcdcError, match="interfacial_model must be one of pairwise, csf") as e:
        SPHConfig.from_dict({"interfacial_model": "surface"})
    assert "\n" not in str(e.value)
    from dcdc.sph.interfaces import coefficients
    with pytest.raises(DcdcError, match="interfacial_model"):
        coefficients("surface", {"oil/water": 1.0}, PH, 0.1, 0.0025, 2)


def test_the_cocktail_scene_pins_the_pairwise_model():
    """The shipped cocktail datasets and networks were made with the pairwise repulsion."""
    from dcdc.scene import get_scene
    cfg = get_scene("cocktail").check_solver()
    assert cfg.interfacial_model == "pairwise" and cfg.interfacial_tension


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="csf without a background pressure: the interface band "
                   "is under tension and clumps, Δp ≈ 0.48 σ/R; with background_pressure = σ/h "
                   "0.83 (2-D quick), 0.79 (2-D full), 0.82 (3-D quick, but max radius 1.16 R): "
                   "docs/sph.md, Known limits")
def test_laplace_quick_2d_csf():
    from dcdc.sph.cases import laplace
    rows = laplace(2, True, SPHConfig(interfacial_model="csf"))
    assert rows[1].passed  # relaxes to round (measured 1.016)
    assert rows[0].passed, rows[0].measured


def _closed_box(dim, r, boundary):
    from dcdc.sph.fixtures import tank_system
    W = 0.2
    sy = tank_system(dim, r, [W] * dim, [(np.zeros(3), [W] * dim + [0] * (3 - dim),
                                          lambda p: np.zeros(len(p), int))],
                     [Phase("a", 1000.0)], wall_height=W, name="box", closed=True)
    sy.gravity[:] = 0.0
    return sy, W


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_a_uniform_background_pressure_exerts_no_force_on_a_uniform_lattice(dim):
    """a_i = -(2 p_b/ρ0) ∇ψ_i: zero on the rest lattice, walls included (they carry p_b
    too); with the volume map only the map's ψ ripple at the walls (< 0.3 % of ψ) is felt."""
    from dcdc.sph.terms import background_acceleration
    pb = 100.0
    for boundary in ("particles", "map"):
        sy, W = _closed_box(dim, 0.0125, boundary)
        sim = Simulator(sy, SPHConfig(background_pressure=pb, boundary=boundary))
        s = sim._state(None)
        nbh = sim._neighbourhood(s)
        a = background_acceleration(pb, s.rho0, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0)
        scale = 2.0 * pb / 1000.0 / sim.h  # a ψ jump of 1 across one support
        inner = np.min(np.minimum(s.x, W - s.x), 1) > sim.h
        assert np.abs(a[inner]).max() < 1e-5 * scale
        if boundary == "particles":
            assert np.abs(a).max() < 1e-9 * scale
            sim.advance(0.1)
            assert np.abs(sy.v).max() < 1e-9  # stays at rest: no force, no pressure
            assert np.abs(sim.pressure()).max() < 1e-6
        else:
            assert np.abs(a).max() < 0.25 * scale


def test_background_pressure_conserves_momentum_and_is_off_by_default():
    """Pairwise antisymmetric: Σ m a = 0 on a disordered cloud without walls (where it does
    push: ∇ψ ≠ 0); 0 (the default) leaves the run bit-for-bit unchanged."""
    from dcdc.geometry import fill_box
    from dcdc.particles import ParticleSystem
    from dcdc.sph.terms import background_acceleration
    r = 0.02
    x = fill_box([0, 0], [0.4, 0.4], 2 * r)
    x = x + np.random.default_rng(2).normal(0, 0.2 * r, x.shape)
    phase = np.random.default_rng(1).integers(0, 2, len(x))
    mk = lambda: ParticleSystem(2, r, x.copy(), np.zeros_like(x), phase,  # noqa: E731
                                [Phase("a", 1000.0), Phase("b", 500.0)], np.zeros((0, 2)),
                                np.zeros((0, 2)), [0, 0], ([-1, -1], [2, 2]))
    sy = mk()
    sim = Simulator(sy, SPHConfig(background_pressure=50.0))
    s = sim._state(None)
    nbh = sim._neighbourhood(s)
    a = background_acceleration(50.0, s.rho0, nbh.rs, nbh.idx, nbh.G, nbh.Sb, s.V0)
    F = (s.rho0 * s.V0)[:, None] * a
    assert np.abs(F).max() > 0
    assert np.abs(F.sum(0)).max() < 1e-10 * np.abs(F).sum()
    for _ in range(5):
        sim.advance(0.02)
    mass = sy.rest_density
    p = (mass[:, None] * sy.v).sum(0)
    assert np.abs(sy.v).max() > 0
    assert np.abs(p).max() < 1e-9 * (mass[:, None] * np.abs(sy.v)).sum()
    assert SPHConfig().background_pressure == 0.0
    a_sy, b_sy = mk(), mk()
    Simulator(a_sy, SPHConfig()).advance(0.02)
    Simulator(b_sy, SPHConfig(background_pressure=0.0)).advance(0.02)
    assert np.array_equal(a_sy.x, b_sy.x) and np.array_equal(a_sy.v, b_sy.v)


@pytest.mark.slow
def test_background_pressure_lifts_the_csf_laplace_jump():
    """p_b = σ/h (the band's peak tension σ|∇c| on the rest lattice, 1.01 σ/h) keeps the
    band from clumping: 2-D quick, Δp 0.48 -> 0.83 σ/R (measured), still round; not yet
    within Young-Laplace's 15 % (the xfail above, docs/sph.md)."""
    from dcdc.sph.cases import laplace
    rows = laplace(2, True, SPHConfig(interfacial_model="csf", background_pressure=10.0 / 0.04))
    assert rows[1].passed
    assert 0.7 < rows[0].measured < 1.15, rows[0].measured


# ---------------------------------------------------------------------------- "curvature" model
def _curvature_fields(dim, densities=(1000.0, 1000.0), sigma=1.0):
    from dcdc.sph.measures import drop_radius
    from dcdc.sph.interfaces import coefficients, curvature_acceleration, pair_curvature
    x, dist, phase, nbh, h, V0 = _lattice_drop(dim, R=0.09 if dim == 2 else 0.07)
    R = drop_radius(int(phase.sum()), V0, dim)
    grad, kappa = pair_curvature(x, phase, 0, 1, nbh.rs, nbh.idx, nbh.G, nbh.W, nbh.Sb, V0, h)
    ph = [Phase("amb", densities[0]), Phase("drop", densities[1])]
    C = coefficients("curvature", {"amb/drop": sigma}, ph, h, V0, dim)
    rho0 = np.array(densities)[phase]
    a = curvature_acceleration(x, phase, rho0, C, nbh.rs, nbh.idx, nbh.G, nbh.W, nbh.Sb, V0, h)
    return x, dist, phase, grad, kappa, (rho0 * V0)[:, None] * a, a, R


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_curvature_of_a_lattice_drop_is_its_radius_and_the_force_young_laplace(dim):
    """On a drop cut from the rest lattice: ∇c points out of the drop (into the ambient,
    phase 0) on both sides and vanishes away from the interface; the band's |∇c|-weighted
    curvature is (d−1)/R in size (measured 1.06, 2-D; 1.03, 3-D); the inward force summed
    over the band is σκ per area (1.05 / 1.00) and its net total is a small part of it."""
    x, dist, phase, grad, kappa, F, _, R = _curvature_fields(dim)
    g = np.linalg.norm(grad, axis=1)
    assert np.all(g[np.abs(dist - R) > 0.1] == 0)
    band = g > 0
    assert np.all((grad[band] * x[band]).sum(1) > 0)  # outward: towards the ambient
    k = (kappa[band] * g[band]).sum() / g[band].sum()
    assert -k * R / (dim - 1) == pytest.approx(1.0, abs=0.08)  # c = 1 outside: κ = −(d−1)/R
    area = 2 * np.pi * R if dim == 2 else 4 * np.pi * R * R
    inward = -(F * x).sum(1) / np.maximum(dist, 1e-12)
    assert inward.sum() / area / ((dim - 1) / R) == pytest.approx(1.0, abs=0.08)
    assert np.abs(F.sum(0)).max() < 0.01 * np.abs(inward).sum()


def test_curvature_force_is_per_volume_and_linear_in_sigma():
    """A force per volume: with unlike densities the force field is that of equal ones (the
    acceleration divided by each particle's density); it scales with σ."""
    *_, F_eq, _, _ = _curvature_fields(2, (1000.0, 1000.0))
    *_, F_ratio, _, _ = _curvature_fields(2, (1000.0, 100.0))
    assert np.allclose(F_ratio, F_eq, rtol=1e-12, atol=1e-15)
    *_, F1, _, _ = _curvature_fields(2, sigma=1.0)
    *_, F3, _, _ = _curvature_fields(2, sigma=3.0)
    assert np.abs(F1).max() > 0 and np.allclose(F3, 3 * F1, rtol=1e-12, atol=1e-15)


@pytest.mark.slow
def test_laplace_quick_2d_curvature_is_young_laplace():
    """The default model's validation row (docs/sph.md, "Interfacial tension"): measured
    Δp 0.93 σ/R, max radius 1.01 R."""
    from dcdc.sph.cases import laplace
    rows = laplace(2, True, SPHConfig(interfacial_model="curvature"))
    assert rows[1].passed, rows[1].measured
    assert rows[0].passed, rows[0].measured


def test_curvature_model_separates_a_random_emulsion_without_blowing_up():
    """The worst case for an estimated curvature, a particle-scale emulsion (single particles
    of one phase in the other, no walls, no gravity): the curvature is bounded by a single
    particle's, (d−1)/r, the run stays bounded and the phases gather (same-phase neighbour
    fraction rises)."""
    from dcdc import metrics
    from dcdc.geometry import fill_box
    from dcdc.particles import ParticleSystem
    r = 0.02
    x = fill_box([0, 0], [0.4, 0.4], 2 * r)
    phase = np.random.default_rng(3).integers(0, 2, len(x))
    sy = ParticleSystem(2, r, x, np.zeros_like(x), phase, [Phase("a", 1000.0), Phase("b", 100.0)],
                        np.zeros((0, 2)), np.zeros((0, 2)), [0, 0], ([-1, -1], [2, 2]))
    before = metrics.neighbour_purity(sy.x, sy.phase, 3.5 * r)
    sim = Simulator(sy, SPHConfig(interfacial_tension={"a/b": 1.0}, interfacial_model="curvature"))
    for _ in range(50):  # 1 s (measured: +0.03 after 0.5 s, +0.12 after 1 s)
        sim.advance(0.02)
    assert np.isfinite(sy.v).all() and np.abs(sy.v).max() < 5.0
    assert metrics.neighbour_purity(sy.x, sy.phase, 3.5 * r) > before + 0.05


def _layers(dim, size=None):
    """Two layers at rest in a closed tank (2:1, the interface at 0.1 m, r = 1.25 cm), by
    default 0.3 × 0.2 (× 0.1) m."""
    from dcdc.sph.fixtures import tank_system
    size = size or [0.3, 0.2] + ([0.1] if dim == 3 else [])
    return tank_system(dim, 0.0125, size, [(np.zeros(3), list(size) + [0] * (3 - dim),
                                            lambda p: (p[:, 1] > 0.1).astype(int))],
                       [Phase("heavy", 2000.0), Phase("light", 1000.0)], wall_height=0.2,
                       name="layers", closed=True)


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_a_flat_interface_meeting_walls_feels_no_curvature_force(dim):
    """Two layers at rest in a closed tank: the interface is flat, so the capillary force is
    zero, also where it meets the walls (contact angle 90°, :func:`wall_contact`; without it
    the colour gradient tilted by 10° at the walls and the tank at rest flowed at 0.56 m/s
    after 1 s, 3-D); after 0.5 s the tank is as quiet as without tension."""
    from dcdc.sph.interfaces import curvature_acceleration
    sy = _layers(dim)
    sim = Simulator(sy, SPHConfig(interfacial_tension={"heavy/light": 10.0}))
    s = sim._state(None)
    nbh = sim._neighbourhood(s)
    a = curvature_acceleration(s.x, s.phase, s.rho0, sim._interface[1], nbh.rs, nbh.idx, nbh.G,
                               nbh.W, nbh.Sb, s.V0, s.h)
    scale = 10.0 / (1000.0 * s.h * s.h)  # σ / (ρ h²): the force of a curvature 1/h
    assert np.abs(a).max() < 0.01 * scale
    sim.run(0.5, 0.02)
    plain = _layers(dim)
    Simulator(plain, SPHConfig()).run(0.5, 0.02)
    assert np.linalg.norm(sy.v, axis=1).max() < 2.0 * np.linalg.norm(plain.v, axis=1).max() + 0.01


@pytest.mark.parametrize("dim", [2, 3])
def test_pairwise_wall_images_cancel_the_walls_push_on_a_flat_interface(dim):
    """Two layers at rest in a closed tank with the "pairwise" repulsion: without the walls'
    images the unlike neighbours push the particles where the interface meets a side wall
    into the wall (the wall is a hole in the repulsion); with them (the method of images, a
    90° contact angle, :func:`pairwise_wall_images`) the wall-normal push is gone there up
    to the volume map's error, and nothing changes away from the walls."""
    from dcdc.sph.interfaces import pairwise_acceleration, pairwise_wall_images, wall_image_table
    size = [0.3, 0.2] + ([0.15] if dim == 3 else [])
    sy = _layers(dim, size)
    sim = Simulator(sy, SPHConfig(interfacial_tension={"heavy/light": 10.0},
                                  interfacial_model="pairwise"))
    s = sim._state(None)
    nbh = sim._neighbourhood(s)
    K = sim._interface[1]
    plain = pairwise_acceleration(s.x, s.phase, s.rho0, K, nbh.rs, nbh.idx, s.h, s.V0)
    images = pairwise_wall_images(s.x, s.phase, s.rho0, K, nbh.rs, nbh.idx, nbh.psi_wall,
                                  nbh.Sb, s.V0, s.h, *wall_image_table(s.h, dim, s.V0))
    side = np.minimum(s.x[:, 0], size[0] - s.x[:, 0]) < s.h  # next to the side walls
    away = np.min(np.minimum(s.x, np.asarray(size) - s.x), 1) > s.h
    others = np.ones(len(s.x), bool)
    if dim == 3:  # leave out the corners with the front and back walls (one plane is mirrored)
        others = np.minimum(s.x[:, 2], size[2] - s.x[:, 2]) > s.h
    band = (np.abs(s.x[:, 1] - 0.1) < s.h) & side & others
    inward = np.abs(plain[band, 0]).max()
    assert inward > 0.1 * np.abs(plain).max()  # the hole in the repulsion is felt
    assert np.abs((plain + images)[band, 0]).max() < 0.05 * inward
    assert np.abs(images[away]).max() == 0.0


def test_a_particle_size_drop_leaves_the_floor_only_above_the_departure_bond_number():
    """A drop of one particle (D = 2r = 5 cm) on a wall with a 90° contact angle detaches when
    its Bond number Δρ g D²/σ exceeds Fritz's departure value, (0.0208 θ)² = 3.5 at θ = 90°
    (Fritz 1935, Phys. Z. 36; D_d = 0.0208 θ sqrt(σ/(gΔρ))). σ = 2 N/m (Bo 16): all four drops
    rise; σ = 20 N/m, the cocktail's (Bo 1.6): none does. Measured (3 s): every
    drop rose at σ = 2, 5, 6 and 8.5 N/m, none at 7, 10 and 20 (2-D; 3-D: 5 all, 10 seven of
    eight, 20 none): the departure lies at Bo ≈ 3-5, Fritz's 3.5 within its noise. This is
    what keeps the 2-D cocktail's last oil particles on the glass (docs/sph.md, "Walls for the
    pairwise tension")."""
    from dcdc.sph.experiments import floor_drops_run
    low = floor_drops_run(2, 2.0, T=2.0)
    assert low["drops"] == 4 and low["risen"] == 1.0
    assert floor_drops_run(2, 20.0, T=2.0)["risen"] == 0.0


def test_wall_tension_is_checked_and_needs_the_pairwise_model():
    from dcdc.sph.interfaces import coefficients
    with pytest.raises(DcdcError, match="wall_tension: 'milk' names no phase"):
        pair_coefficients({"oil/water": 1.0}, PH, 0.1, 0.0025, 2, {"milk": 1.0})
    with pytest.raises(DcdcError, match="needs sph.interfacial_tension"):
        coefficients("curvature", {"oil/water": 1.0}, PH, 0.1, 0.0025, 2, {"oil": 1.0})
    with pytest.raises(DcdcError, match="needs sph.interfacial_tension"):
        pair_coefficients({}, PH, 0.1, 0.0025, 2, {"oil": 1.0})
    with pytest.raises(DcdcError, match="wall_tension.oil must be a finite number >= 0"):
        SPHConfig(wall_tension={"oil": -1.0})
    # only differences matter: the smallest wall tension is taken out; the walls' column is
    # twice σ_w / S (each half of the mirrored system carries half the mirror plane's tension)
    K = pair_coefficients({"oil/water": 2.0}, PH, 0.1, 0.0025, 2, {"oil": 3.0, "water": 1.0,
                                                                     "juice": 1.0})
    assert K.shape == (4, 4) and K[3, 1] == 0 and K[3, 2] == 0
    assert K[3, 0] == pytest.approx(2.0 * K[0, 1]) and K[0, 3] == K[3, 0]


@pytest.mark.slow
@pytest.mark.parametrize("theta", [120.0])
def test_a_drop_from_90_degrees_dewets_to_youngs_120_degrees(theta):
    """A 2-D half-disc drop (R = 8 spacings, 1 250 particles, no gravity) on a wall whose
    tensions give Young's angle θ through the drop, cos θ = (σ_w,ambient − σ_w,drop) / σ:
    from its 90° start its contact line recedes until θ. Measured
    (`benchmarks/contact_angle.py`): 119° at 3 s for 120°; 86° for 90°; 60° is approached
    slowly (69° at 4 s). With the walls' coefficient σ_w / S instead of 2σ_w / S the 120°
    drop stopped at 110° (the mirrored system's factor two). Not tested because not true:
    from a 150° start the drop does not come back (138° for 90°, 167° for 120°; docs/sph.md,
    "Wetting")."""
    from dcdc.sph.experiments import sessile_drop_run
    m = sessile_drop_run(2, theta, duration=3.0)
    assert abs(m["theta"][-1] - theta) < 8.0, m["theta"]
    assert m["theta"][0] < m["theta"][-1]  # it moved there from 90°
