"""The built-in showcases show their phenomenon: checked on coarse 2-D variants
(the README reports the default resolutions)."""
import functools

import numpy as np
import pytest

from dcdc import metrics
from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig


def _run(name, dim, resolution):
    scene = get_scene(name)
    sy = scene.realize(dim, resolution)
    sim = Simulator(sy, SPHConfig.from_dict(scene.solver))
    sim.run(scene.data["duration"], 0.02)
    return sy


@functools.lru_cache(maxsize=1)
def _cocktail():
    """The 2-D cocktail at the demo's resolution (~1 700 particles), run once for both
    checks: order, purity per phase and each phase's share left at the glass under denser
    fluid."""
    sy = _run("cocktail", 2, 2.0)
    layers = metrics.layer_summary(sy.x, sy.phase, [p.density for p in sy.phases], sy.wall_x,
                                   sy.radius)
    return layers["order"], layers["purity"], layers["trapped"]


@pytest.mark.slow
def test_cocktail_ends_in_four_clean_layers():
    """At the demo's resolution (at ~420 particles the water layer's purity is 0.85).
    Measured at 15 s with the scene's oil-repelling glass, three starts: purity per phase
    0.92-0.96, oil at the glass 0 %, water <= 0.4 %. With a neutral glass (the pairwise
    tension's wall images, 90°): purity 0.91-0.98, oil at the glass 2.4 / 1.0 / 1.0 %, water
    <= 0.4 %, juice <= 0.2 %; without any pressure reference (one start) purity 0.884-0.904,
    oil 7.8 %; without interfacial tension purity 0.74. No phase lines the glass (< 10 % of
    each)."""
    order, purity, trapped = _cocktail()
    assert order
    assert (purity >= 0.85).all(), purity
    assert (trapped < 0.1).all(), trapped


@pytest.mark.slow
def test_cocktail_leaves_under_one_percent_of_each_phase_at_the_glass():
    """The showcase's < 1 %. Measured (the scene's oil-repelling glass, three starts):
    oil 0 / 0 / 0 %, water 0.2-0.4 %, juice and grenadine 0. With a neutral glass (90° for
    every pair) the oil keeps 2.4 / 1.0 / 1.0 % as one-particle drops on the
    bowl's bottom, below their departure size (docs/sph.md, "Wetting")."""
    assert (_cocktail()[2] < 0.01).all(), _cocktail()[2]


@pytest.mark.slow
def test_3d_cocktail_ends_in_clean_layers_with_under_one_percent_at_the_glass():
    """The cocktail's targets in 3-D: the scene in a 0.7× glass (2 392 particles of the
    default r = 2.5 cm, its 15 s and solver; ~55 s): four layers in density order, purity
    >= 0.9 per phase and < 1 % of every phase held at the glass under denser fluid.
    Measured with the scene's oil-repelling glass: none held from the lattice start and
    from two starts perturbed by 0.1 mm, purity >= 0.993. With a neutral glass: none from the
    lattice start, 0.44 % of the oil (1 of 228) from a perturbed one, purity >= 0.995;
    without the pairwise tension's wall images
    (:func:`dcdc.sph.interfaces.pairwise_wall_images`) 2.2 % of the oil stays (the full-size
    3-D cocktail: 2.6 %). A 0.6× glass spills water onto the table
    at the start, whose median height then fails the order."""
    sy = _run("cocktail", 3, 0.7)
    layers = metrics.layer_summary(sy.x, sy.phase, [p.density for p in sy.phases], sy.wall_x,
                                   sy.radius)
    assert layers["order"]
    assert (layers["purity"] >= 0.9).all(), layers["purity"]
    assert (layers["trapped"] < 0.01).all(), layers["trapped"]


@pytest.mark.slow
def test_hourglass_drains_the_heavy_phase():
    sy = _run("hourglass", 2, 1.0)
    heavy = np.flatnonzero([p.name == "heavy" for p in sy.phases])[0]
    below = np.mean(sy.x[sy.phase == heavy, 1] < 0.9)  # the neck is at half the 1.8 m cavity
    # the showcase's target: >= 90 % within the scene's duration (15 s). Measured with the
    # scene's closed-container settings and interfacial tension: 100 % at 15 s in three
    # starts (88-100 % at 10 s, 56-78 % at 5 s; the exchange through the neck is chaotic);
    # without the tension 99.6-100 % at 15 s here but not converged at finer radii; with the
    # open-scene defaults 88 % at 15 s, 96 % at 22 s
    assert below >= 0.9, below


@pytest.mark.slow
def test_canyon_heavy_phase_collects_in_the_depressions():
    """The 2-D canyon section at the scene's resolution and duration (271 particles, 5 s):
    the heavy phase ends in the basins (pooled: fluid >= 3 rows deep above its floor, not a
    film on a slope) under the lighter ones. Measured: 94 % pooled, 6 % of the pooled
    particles with a lighter one below them, order right (3-D at the default resolution:
    94 % / 0.7 %). The start, three blocks side by side on the slope, fails the order."""
    scene = get_scene("canyon")
    sy = scene.realize(2, 1.0)
    dens = np.array([p.density for p in sy.phases])
    assert not metrics.density_order_ok(sy.x, sy.phase, dens)
    sim = Simulator(sy, SPHConfig.from_dict(scene.solver))
    sim.run(scene.data["duration"], 0.02)
    assert metrics.density_order_ok(sy.x, sy.phase, dens)
    pooled, inverted = metrics.pooled_heavy(sy.x, sy.phase, dens, sy.wall_x, sy.radius)
    assert pooled >= 0.9 and inverted < 0.1, (pooled, inverted)
