"""Scene families (dcdc.scene.families), the emulsion block (phases = [...]) and
`dcdc generate --family`."""
import numpy as np
import pytest

from dcdc.errors import DcdcError
from dcdc.scene import parse
from dcdc.scene.families import (FAMILIES, PARTICLES, RATIO_RANGE, SUITE_SEED0, TENSION,
                                 density_ratio, draw_densities, family_scene_text)
from helpers import dcdc

EMULSION = """
name = "emu"
dim = 2
seed = 7
[domain]
min = [0.0, 0.0]
max = [1.0, 1.0]
[phases.a]
density = 1000
[phases.b]
density = 1200
[phases.c]
density = 1500
[walls.tank]
shape = "box"
min = [0.0, 0.0]
max = [1.0, 1.0]
hollow = true
[[fluid]]
phases = ["a", "c"]
fractions = [3, 1]
shape = "box"
min = [0.0, 0.0]
max = [1.0, 0.5]
"""


def test_emulsion_block_random_phase_per_particle():
    s = parse(EMULSION).realize()
    assert s.n_fluid == 200
    counts = np.bincount(s.phase, minlength=3)
    assert counts[1] == 0 and counts[0] + counts[2] == 200
    assert 0.6 < counts[0] / 200 < 0.9  # fractions 3:1
    again = parse(EMULSION).realize()
    assert (again.phase == s.phase).all()  # seeded by the scene's seed
    other = parse(EMULSION.replace("seed = 7", "seed = 8")).realize()
    assert (other.phase != s.phase).any()


@pytest.mark.parametrize("edit, msg", [
    ('phases = ["a", "c"]', "needs phase"),  # neither
    ('phases = ["a", "x"]', "names no phase"),
    ('phases = ["a", "a"]', "twice"),
    ('phases = []', "list of phase names"),
])
def test_emulsion_block_errors(edit, msg):
    text = EMULSION.replace('fractions = [3, 1]\n', '')
    text = text.replace('phases = ["a", "c"]', edit if edit != 'phases = ["a", "c"]' else "")
    with pytest.raises(DcdcError, match=msg):
        parse(text)


def test_emulsion_fraction_errors():
    with pytest.raises(DcdcError, match="fractions"):
        parse(EMULSION.replace("fractions = [3, 1]", "fractions = [1, 0]"))
    with pytest.raises(DcdcError, match="fractions"):
        parse(EMULSION.replace("fractions = [3, 1]", "fractions = [1]"))
    with pytest.raises(DcdcError, match="one of them"):
        parse(EMULSION.replace('phases = ["a", "c"]', 'phase = "a"\nphases = ["a"]'))
    with pytest.raises(DcdcError, match="phases"):
        parse(EMULSION.replace('phases = ["a", "c"]\nfractions = [3, 1]', 'phase = "a"\nfractions = [1]'))


def test_density_draws():
    rng = np.random.default_rng(0)
    ratios = []
    for k in (2, 3, 4) * 300:
        d = draw_densities(rng, k)
        assert len(set(d)) == k and min(d) >= 200 and max(d) <= 5000
        ratios.append(max(d) / min(d))
    ratios = np.array(ratios)
    assert ratios.min() >= RATIO_RANGE[0] and ratios.max() <= RATIO_RANGE[1]
    assert 0.4 < (ratios <= 1.5).mean() < 0.6
    assert (ratios > 10).any()


@pytest.mark.parametrize("dim, seeds", [(2, range(SUITE_SEED0, SUITE_SEED0 + 6)), (2, range(3)),
                                        (3, range(SUITE_SEED0, SUITE_SEED0 + 1))])
def test_family_scenes_parse(dim, seeds):
    lo, hi = PARTICLES[dim]
    starts = set()
    for fam in FAMILIES:
        for seed in seeds:
            text = family_scene_text(fam, seed, dim)
            assert text == family_scene_text(fam, seed, dim)  # deterministic
            sc = parse(text, f"{fam}_{seed}")
            assert sc.dim == dim and sc.duration == 4.0 and sc.frame_dt == 0.02
            s = sc.realize()
            assert lo <= s.n_fluid <= hi
            names = list(sc.data["phases"])
            assert 2 <= len(names) <= 4
            assert len(np.unique(s.phase)) == len(names)
            assert RATIO_RANGE[0] <= density_ratio(text) <= RATIO_RANGE[1]
            cfg = sc.check_solver()
            assert cfg.interfacial_model == "curvature"
            assert len(cfg.interfacial_tension) == len(names) * (len(names) - 1) // 2
            assert set(cfg.interfacial_tension.values()) == {TENSION}
            if fam == "hourglass":
                assert cfg.reference_surface is False
            starts.add(sc.data["description"].split("; ")[1].split(" start")[0])
    if dim == 2 and len(seeds) >= 6:
        assert starts == {"layered", "emulsion", "sloshing", "tilted"}



def test_generate_family_seed_separation(tmp_path, capsys):
    code, out, err = dcdc(capsys, "generate", "--family", "all", "--random", 2, "--seed",
                          SUITE_SEED0 - 1, "-o", tmp_path / "a")
    assert code == 2 and err.startswith("error:") and "--split test" in err
    assert len(err.strip().splitlines()) == 1
    code, out, err = dcdc(capsys, "generate", "--family", "mesh", "--random", 1, "--seed", 3,
                          "--duration", 0.02, "--simulator", "ballistic", "-o", tmp_path / "b",
                          "--no-progress")
    assert code == 0, err
    assert (tmp_path / "b" / "mesh_3_2d.h5").exists()
    code, out, err = dcdc(capsys, "generate", "--family", "box_emulsion", "--random", 1, "--seed",
                          SUITE_SEED0, "--split", "test", "--duration", 0.02, "--simulator",
                          "ballistic", "-o", tmp_path / "c", "--no-progress")
    assert code == 0, err
    assert (tmp_path / "c" / f"box_emulsion_{SUITE_SEED0}_2d.h5").exists()
