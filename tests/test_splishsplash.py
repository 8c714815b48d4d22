"""SPlisHSPlasH scene translation (always) and a short run (only when pysplishsplash is installed)."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.geometry import fill_box
from dcdc.particles import ParticleSystem, Phase
from dcdc.sph import splishsplash as ss


def two_blocks(ratio=10.0):
    a = fill_box([0, 0, 0], [0.3, 0.3, 0.3], 0.05)
    b = fill_box([0.3, 0, 0], [0.6, 0.3, 0.3], 0.05)
    x = np.concatenate([a, b])
    ph = np.r_[np.zeros(len(a)), np.ones(len(b))]
    return ParticleSystem(3, 0.025, x, np.zeros_like(x), ph,
                          [Phase("heavy", 1000.0 * ratio), Phase("light", 1000.0)],
                          np.zeros((0, 3)), np.zeros((0, 3)), (0, -9.81, 0),
                          ([-1, -1, -1], [2, 2, 2]), meta={"container": ([0, 0, 0], [0.6, 0.6, 0.3])})


def test_scene_translation_keeps_blocks_and_densities():
    s = two_blocks()
    scene = ss.scene_json(s, s.meta["container"], 0.1, "IISPH", "box.obj")
    assert [m["density0"] for m in scene["Materials"]] == [10000.0, 1000.0]
    blocks = {b["id"]: b for b in scene["FluidBlocks"]}
    np.testing.assert_allclose(blocks["heavy"]["start"], [-0.025] * 3, atol=1e-12)
    np.testing.assert_allclose(blocks["light"]["end"], [0.625, 0.325, 0.325], atol=1e-12)
    assert scene["Configuration"]["simulationMethod"] == ss.SOLVERS["IISPH"]


def test_non_block_phase_is_refused():
    s = two_blocks()
    s.x = s.x[::2].copy()
    s.v, s.phase, s.birth = s.v[::2].copy(), s.phase[::2].copy(), s.birth[::2].copy()
    with pytest.raises(DcdcError, match="not a single filled box"):
        ss.phase_blocks(s)
    with pytest.raises(DcdcError, match="unknown SPlisHSPlasH solver"):
        ss.scene_json(two_blocks(), ([0, 0, 0], [1, 1, 1]), 0.1, "NOPE", "box.obj")


@pytest.mark.skipif(not ss.available(), reason="pysplishsplash not installed")
def test_short_run_keeps_particles_and_layers():
    r = ss.run_splishsplash(two_blocks(2.0), 0.25, "IISPH", timeout=300)
    assert r["status"] == "ok"
    assert r["fluid_particles"] == len(two_blocks().x)
    # the heavy block slumps under the light one: its centroid ends lower
    assert r["phases"]["heavy"]["centroid"][1] < r["phases"]["light"]["centroid"][1]
