"""Random training scenes with one interfacial tension between every pair of phases
(`dcdc generate --random N --tension σ`), the physics of the family scenes."""
import pytest
from click.testing import CliRunner

from dcdc.cli import cli
from dcdc.errors import DcdcError
from dcdc.scene import parse
from dcdc.scene.random import RandomSceneConfig, random_scene_text
from dcdc.sph import SPHConfig


def _multiphase_seeds(cfg, n=3):
    out = []
    for seed in range(40):
        if len(parse(random_scene_text(seed, cfg)).data["phases"]) > 1:
            out.append(seed)
        if len(out) == n:
            return out
    raise AssertionError("no multiphase random scene in 40 seeds")


def test_every_pair_gets_the_tension_and_the_file_parses():
    cfg = RandomSceneConfig(dim=2, tension=20.0)
    for seed in _multiphase_seeds(cfg):
        text = random_scene_text(seed, cfg)
        scene = parse(text)
        names = list(scene.data["phases"])
        tension = scene.data["solver"]["interfacial_tension"]
        assert len(tension) == len(names) * (len(names) - 1) // 2
        assert set(tension.values()) == {20.0}
        assert "--tension 20" in text.splitlines()[0]
        assert SPHConfig.from_dict(scene.data["solver"]).interfacial_model == "curvature"


def test_no_tension_writes_no_solver_table_and_the_same_scene():
    seed = _multiphase_seeds(RandomSceneConfig(dim=2))[0]
    plain = parse(random_scene_text(seed, RandomSceneConfig(dim=2))).data
    tense = parse(random_scene_text(seed, RandomSceneConfig(dim=2, tension=5.0))).data
    assert not plain.get("solver", {}).get("interfacial_tension")
    assert tense["solver"].pop("interfacial_tension")
    assert tense == plain  # the tension adds a table and changes nothing else


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_bad_tension_is_refused(bad):
    with pytest.raises(DcdcError, match="--tension"):
        RandomSceneConfig(tension=bad).check()


def test_generate_refuses_tension_outside_random_scenes(tmp_path):
    r = CliRunner().invoke(cli, ["generate", "--family", "glass", "--random", "1", "--tension", "5",
                                  "-o", str(tmp_path / "d")])
    assert r.exit_code != 0 and "--tension applies to --random scenes only" in str(r.exception)
    r = CliRunner().invoke(cli, ["generate", "dam_break", "--tension", "5", "-o", str(tmp_path / "e")])
    assert r.exit_code != 0 and "--tension" in str(r.exception)
