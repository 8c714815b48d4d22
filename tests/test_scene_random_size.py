"""2-D random training scenes large enough to teach collective flow."""
import numpy as np

from dcdc.scene import parse
from dcdc.scene.random import RandomSceneConfig, random_scene_text


def test_2d_random_scenes_hold_about_a_thousand_particles():
    n = [parse(random_scene_text(s, RandomSceneConfig(dim=2))).realize().n_fluid for s in range(12)]
    assert min(n) >= 700 and np.median(n) >= 1000, n


def test_size_knob_scales_the_scene():
    def area(cfg, seeds=range(6)):
        d = [parse(random_scene_text(s, cfg)).data["domain"] for s in seeds]
        return np.mean([np.prod(np.subtract(x["max"], x["min"])) for x in d])
    small = area(RandomSceneConfig(dim=2, size=1.0, min_particles=100))
    assert area(RandomSceneConfig(dim=2)) > 3 * small  # default 2-D size 2: ~4x the area
