"""The README's main job: ``dcdc demo`` writes a complete trajectory, pictures and a PLY."""
import json
import pytest
import subprocess
import sys

import numpy as np

from dcdc.data.dataset import Dataset, is_complete
from dcdc.errors import DcdcError
from dcdc.demo import default_resolution, order_ok, stratification


@pytest.mark.slow
def test_demo_writes_complete_outputs(tmp_path):
    """0.1 s is too short for the cocktail (light oil starts at the bottom) to re-stratify:
    the outputs are written all the same (SPH and, by default, the shipped dcdc2d beside it),
    and the order check fails with exit 2 and one line."""
    r = subprocess.run([sys.executable, "-m", "dcdc.cli", "demo", "--duration", "0.1",
                        "--out", str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    errors = [ln for ln in r.stderr.splitlines()  # without the tqdm bars (frames, steps)
              if "frame" not in ln and "step" not in ln and ln.strip()]
    assert errors == [errors[0]] and errors[0].startswith("error: stratification order (heavy below) failed"), r.stderr
    h5 = tmp_path / "cocktail_2d_res2.h5"
    assert is_complete(h5)
    traj = Dataset(tmp_path)["cocktail_2d_res2"]
    assert traj.n_frames == 6 and np.isfinite(traj.position).all()
    for name in ("cocktail_2d_res2.png", "cocktail_2d_res2.gif", "cocktail_2d_res2_final.ply"):
        assert (tmp_path / name).stat().st_size > 1000
    assert "stratification order (heavy below): NO" in r.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "cocktail_2d_res2.gif", "cocktail_2d_res2.h5", "cocktail_2d_res2.png",
        "cocktail_2d_res2_dcdc.h5", "cocktail_2d_res2_dcdc_compare.gif",
        "cocktail_2d_res2_dcdc_compare.png", "cocktail_2d_res2_final.ply", "demo.txt"]
    assert "learned model dcdc2d: 5 of 5 steps" in r.stdout
    assert "stratification order (heavy below): NO" in (tmp_path / "demo.txt").read_text()


@pytest.mark.slow
def test_demo_bad_scene_is_one_line_error(tmp_path):
    r = subprocess.run([sys.executable, "-m", "dcdc.cli", "demo", "--scene", "nope",
                        "--out", str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.startswith("error:") and len(r.stderr.strip().splitlines()) == 1


class _Traj:
    """Two phases; heights given per frame."""
    def __init__(self, heights):
        from dcdc.particles import Phase
        self.phases = [Phase("light", 500.0), Phase("heavy", 3000.0)]
        self.phase = np.array([0, 0, 1, 1])
        self.birth = np.zeros(4)
        self.time = np.array([0.0])
        y = np.array(heights, dtype=float)
        self.position = np.stack([np.zeros(4), y], 1)[None]


def test_demo_scales_up_only_the_2d_cocktail():
    assert default_resolution("cocktail", 2) == 2.0
    assert default_resolution("cocktail", 3) == 1.0  # 8 048 particles already
    assert default_resolution("hourglass", 2) == 1.0


def test_stratification_order():
    assert order_ok(_Traj([1.0, 1.2, 0.1, 0.2]), 0)
    assert not order_ok(_Traj([0.1, 0.2, 1.0, 1.2]), 0)
    assert [r[0] for r in stratification(_Traj([0.1, 0.2, 1.0, 1.2]), 0)] == ["light", "heavy"]
    assert stratification(_Traj([0.1, 0.3, 1.0, 1.2]), 0)[0][2] == 0.2  # median height


@pytest.mark.slow
def test_demo_runs_a_shipped_model_beside_sph(tmp_path, capsys):
    """dcdc demo --model: the learned model runs the same scene from the same start; its
    trajectory and the SPH-above-model strip are written, its numbers printed."""
    from helpers import dcdc_output

    out = tmp_path / "demo"
    code, stdout, _ = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.4",
                                   "--model", "dcdc2d", "--out", out], capsys)
    assert code == 0
    assert "learned model dcdc2d: 20 of 20 steps" in stdout
    # the final state against SPH's: one row per phase, then the summary line
    rows = [ln.split() for ln in stdout.splitlines() if ln.split()[:1] in (["light"], ["heavy"])]
    assert len(rows) == 4  # the SPH table's two rows and the model's two
    heights = {r[0]: [float(v) for v in r[1:]] for r in rows[2:]}
    for sph, mine, rel, *_ in heights.values():  # printed to 3 decimals: within their rounding
        assert abs(rel - abs(mine - sph) / sph) <= 0.001 / sph + 0.0005 + 1e-9
    assert "centre-of-mass height error" in stdout and "stratification order (heavy below): yes" in stdout
    assert "verdict: layers like SPH, stratification order (heavy below): yes" in stdout
    assert "the network alone (no wall contact)" in stdout  # dcdc2d's default
    for _, _, _, p_sph, p_mine, w1 in heights.values():  # purity in [0, 1], W1 a fraction
        assert 0 <= p_sph <= 1 and 0 <= p_mine <= 1 and 0 <= w1 < 0.05
    assert (out / "lock_exchange_2d_dcdc.h5").is_file()
    assert (out / "lock_exchange_2d_dcdc_compare.png").stat().st_size > 10_000
    import imageio.v3 as iio
    gif = iio.imread(out / "lock_exchange_2d_dcdc_compare.gif", index=None)
    assert gif.shape[0] == 11  # frames 0, 2, ..., 20 of SPH | model
    assert gif.shape[2] > 2 * 360 - 1  # two panels side by side
    from dcdc.data.dataset import Dataset
    pred = Dataset(out / "lock_exchange_2d_dcdc.h5")["lock_exchange_2d_dcdc"]
    assert pred.n_frames == 21 and np.isfinite(pred.position).all()


def test_demo_refuses_a_model_of_another_dimension_before_simulating(tmp_path, capsys):
    from helpers import dcdc_output

    code, _, err = dcdc_output(["demo", "--scene", "lock_exchange", "--dim", "3", "--model",
                                "dcdc2d", "--out", tmp_path / "d"], capsys)
    assert code == 2 and "2-D" in err and "Traceback" not in err
    assert not (tmp_path / "d").exists()


@pytest.mark.slow
def test_demo_settle_hands_the_model_the_sph_state(tmp_path, capsys):
    """dcdc demo --model --settle T: the network starts from the SPH frame at T; its file
    repeats the SPH frames up to T, so both share frame times; misuse is a one-line error."""
    from helpers import dcdc_output

    out = tmp_path / "demo"
    code, stdout, _ = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.4",
                                   "--model", "dcdc2d", "--settle", "0.1", "--out", out], capsys)
    assert code == 0
    assert "learned model dcdc2d from the SPH state at 0.1 s: 15 of 15 steps" in stdout
    ds = Dataset(out)
    sph, pred = ds["lock_exchange_2d"], ds["lock_exchange_2d_dcdc"]
    assert pred.n_frames == sph.n_frames == 21
    np.testing.assert_allclose(pred.time, sph.time, atol=1e-9)
    np.testing.assert_allclose(pred.position[:6], sph.position[:6], atol=1e-6)  # frame 5 = start
    assert np.abs(pred.position[-1] - sph.position[-1]).max() > 0  # the network ran after it
    stats = json.loads(pred.attrs["solver_stats"])  # the network's steps, not the SPH frames
    assert (stats["steps"], stats["sph_frames"]) == (15, 5)
    assert len(stats["in_walls"]) == 20 and float(pred.attrs["settled_by_sph_s"]) == 0.1
    for args, msg in ((["--model", "none", "--settle", "0.1"], "not with --model none"),
                      (["--model", "dcdc2d", "--settle", "0.4"], "not before the end"),
                      (["--model", "dcdc2d", "--settle", "0.03"], "multiple of")):
        code, _, err = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.4",
                                    *args, "--out", tmp_path / "bad"], capsys)
        assert code == 2 and msg in err and "Traceback" not in err, err
        assert not (tmp_path / "bad").exists()


@pytest.mark.slow
def test_demo_model_none_and_a_scene_the_shipped_model_does_not_fit(tmp_path, capsys):
    """--model none runs SPH alone; the default model is skipped, with a note, on a scene
    whose particle radius is not the one it was trained for (an explicit --model fails)."""
    from helpers import dcdc_output

    from dcdc.data.jobs import scene_jobs

    out = tmp_path / "none"
    code, stdout, _ = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.1",
                                   "--model", "none", "--out", out], capsys)
    assert code == 0 and "learned model" not in stdout
    assert sorted(p.suffix for p in out.iterdir()) == [".gif", ".h5", ".ply", ".png", ".txt"]
    text = scene_jobs(["lock_exchange"], dim=2)[0].text()
    scene = tmp_path / "fine.toml"
    scene.write_text(text.replace('dim = 3', 'dim = 3\nradius = 0.02'))
    code, stdout, _ = dcdc_output(["demo", "--scene", scene, "--dim", "2", "--duration",
                                   "0.1", "--out", tmp_path / "auto"], capsys)
    assert code == 0, stdout
    assert "no learned model: the model is trained for particle radius 0.025 m" in stdout
    assert not any("_dcdc" in p.name for p in (tmp_path / "auto").iterdir())
    code, _, err = dcdc_output(["demo", "--scene", scene, "--dim", "2", "--duration", "0.1",
                                "--model", "dcdc2d", "--out", tmp_path / "strict"], capsys)
    assert code == 2 and "particle radius" in err and "Traceback" not in err
    assert not (tmp_path / "strict").exists()


def test_demo_keeps_the_sph_run_when_the_network_fails_and_overwrite_empties(tmp_path, capsys,
                                                                            monkeypatch):
    """Each result is written when it exists: a failure in the learned part leaves the SPH
    trajectory and pictures but no demo.txt (the mark of a finished demo); --overwrite
    empties the folder first, so no file of an earlier run stays."""
    from helpers import dcdc_output

    import dcdc.demo as demo

    def broken(*a, **k):
        raise DcdcError("the network broke")
    monkeypatch.setattr(demo, "_neural_beside", broken)
    out = tmp_path / "d"
    code, stdout, err = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.1",
                                     "--out", out], capsys)
    assert code == 2 and "the network broke" in err
    assert is_complete(out / "lock_exchange_2d.h5") and (out / "lock_exchange_2d.png").is_file()
    assert not (out / "demo.txt").exists() and f"wrote {out / 'lock_exchange_2d.h5'}" in stdout
    (out / "stale.txt").write_text("an earlier run")
    code, _, _ = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.1",
                              "--model", "none", "--out", out], capsys)
    assert code == 2  # without --overwrite a non-empty folder is refused
    code, _, _ = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.1",
                              "--model", "none", "--overwrite", "--out", out], capsys)
    assert code == 0 and not (out / "stale.txt").exists() and (out / "demo.txt").is_file()


def test_demo_verdict_names_what_fails():
    """The verdict: the order first, then which phases are more mixed or off in height."""
    from dcdc.demo import verdict

    class P:
        def __init__(self, name):
            self.name = name
    phases = [P("oil"), P("water")]
    good = {"order_ok": True, "layers_ok": True, "purity_ratio": [1.0, 0.95],
            "height_w1_rel": [0.01, 0.02]}
    assert verdict(good, phases) is None
    assert verdict({**good, "order_ok": False}, phases) == "stratification order (heavy below): NO"
    why = verdict({**good, "layers_ok": False, "purity_ratio": [0.7, 0.95],
                   "height_w1_rel": [0.01, 0.08]}, phases)
    assert "more mixed than SPH" in why and "in oil" in why and "in water" in why


def test_demo_fails_when_the_learned_model_ends_in_the_wrong_order(tmp_path, capsys,
                                                                   monkeypatch):
    """SPH's order right but the model's wrong: exit 2 with a one-line reason naming the
    model (its outputs are still written)."""
    from helpers import dcdc_output

    import dcdc.demo as demo

    monkeypatch.setattr(demo, "_neural_beside",
                        lambda *a, **k: ("learned model: stub", "stratification order (heavy below): NO"))
    code, _, err = dcdc_output(["demo", "--scene", "lock_exchange", "--duration", "0.1",
                                "--out", tmp_path / "d"], capsys)
    assert code == 2 and "the learned model dcdc2d fails the demo's verdict" in err
    assert "stratification order (heavy below): NO" in err
    assert [ln for ln in err.splitlines() if ln.startswith("error:")] == [err.splitlines()[-1]]
    assert (tmp_path / "d" / "lock_exchange_2d.h5").is_file()


def test_demo_names_outputs_after_the_scene_file_and_estimates_first(tmp_path, capsys):
    """--scene my.toml: every output is named after the file (my_2d.*), not after the
    scene's name key (a copy of a built-in keeps the built-in's); before each run the demo
    prints the particles, the work and an estimated time."""
    from helpers import dcdc_output

    from dcdc.scene import builtin_text

    scene = tmp_path / "my.toml"
    scene.write_text(builtin_text("lock_exchange"))
    out = tmp_path / "d"
    _, stdout, err = dcdc_output(["demo", "--scene", str(scene), "--dim", "2", "--duration",
                                  "0.1", "--out", str(out)], capsys)
    assert "Traceback" not in err
    assert sorted(p.name for p in out.iterdir()) == [
        "demo.txt", "my_2d.gif", "my_2d.h5", "my_2d.png", "my_2d_dcdc.h5",
        "my_2d_dcdc_compare.gif", "my_2d_dcdc_compare.png", "my_2d_final.ply"]
    n = f"{len(Dataset(out)['my_2d'].phase):,}".replace(",", " ")  # fluid particles
    lines = stdout.splitlines()
    sph = next(i for i, ln in enumerate(lines) if ln.startswith("SPH: "))
    assert lines[sph].startswith(f"SPH: {n} particles, 0.1 s simulated (20 substeps), about ")
    assert lines[sph].endswith(" s on 2 cores")
    assert lines[sph + 1].startswith("simulating my_2d (5 frames")
    net = next(i for i, ln in enumerate(lines) if ln.startswith("learned model dcdc2d: "))
    assert lines[net].startswith(f"learned model dcdc2d: {n} particles, 5 steps, about ")
    assert lines[net + 1].startswith("simulating my_2d with the learned model dcdc2d")


def test_demo_estimate_and_output_name():
    from dcdc.demo import duration_text, estimate, output_name

    assert estimate("SPH", 2000, 3000, 1e-4, "15 s simulated ({} substeps)") == \
        "SPH: 2 000 particles, 15 s simulated (3 000 substeps), about 10 min on 2 cores"
    assert estimate("learned model dcdc2d", 1696, 750, 1.7e-5, "{} steps") == \
        "learned model dcdc2d: 1 696 particles, 750 steps, about 20 s on 2 cores"
    assert [duration_text(s) for s in (3, 47, 600, 7200)] == \
        ["about 3 s", "about 50 s", "about 10 min", "about 2.0 h"]
    assert output_name("cocktail", "cocktail_2d_res2", "cocktail") == "cocktail_2d_res2"
    assert output_name("runs/my scene.toml", "hourglass_3d", "hourglass") == "my_scene_3d"
