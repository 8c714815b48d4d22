"""dcdc.evaluate.scores and `dcdc evaluate` against the sample SPH trajectories."""
import json

import numpy as np
import pytest
import torch

from dcdc import metrics as M
from dcdc.data.dataset import Dataset
from dcdc.errors import DcdcError
from dcdc.evaluate.rollout import Guard
from dcdc.evaluate.scores import (aggregate, number_density, one_two_step_errors, perturbed_start,
                                  score_members, score_trajectory)
from dcdc.model.checkpoint import save_checkpoint
from dcdc.model.networks import build_network
from helpers import dcdc_output as _cli

SAMPLE = "data/sample/test2d"
DT = 0.02


def zero_net(dim=2):
    net = build_network("cconv", dim)
    for p in net.parameters():
        p.data.zero_()
    return net


def test_n1_n2_errors_of_the_ballistic_model_by_hand():
    traj = Dataset(SAMPLE)["random_200000_2d"]
    e1, e2, starts = one_two_step_errors(zero_net(), traj, stride=5)
    g = traj.gravity
    ref1, ref2 = [], []
    for f in range(0, traj.n_frames - 2, 5):
        x, v = traj.position[f].astype(float), traj.velocity[f].astype(float)
        x1 = x + DT * v + 0.5 * DT * DT * g
        v1 = (x1 - x) / DT
        x2 = x1 + DT * v1 + 0.5 * DT * DT * g
        ref1.append(np.linalg.norm(x1 - traj.position[f + 1], axis=1).mean())
        ref2.append(np.linalg.norm(x2 - traj.position[f + 2], axis=1).mean())
    assert starts == len(range(0, traj.n_frames - 2, 5)) == 10
    assert e1 == pytest.approx(np.mean(ref1), rel=1e-4)
    assert e2 == pytest.approx(np.mean(ref2), rel=1e-4)


def test_number_density_is_one_inside_a_lattice():
    g = (np.arange(11) - 5) * 0.05
    x = np.array([(a, b) for a in g for b in g])
    psi, V0 = number_density(x, 0.025, np.zeros((0, 2)))
    centre = np.flatnonzero((np.abs(x) < 1e-9).all(1))[0]
    assert psi[centre] == pytest.approx(1.0, abs=1e-9)
    corner = np.argmin(x.sum(1))
    assert psi[corner] < 0.75 and psi.max() == pytest.approx(1.0)  # corners miss neighbours
    assert V0 == pytest.approx(0.05 ** 2, rel=0.01)


def test_score_trajectory_fields_and_truth_metrics():
    traj = Dataset(SAMPLE)["random_200000_2d"]
    r = score_trajectory(zero_net(), traj, stride=10, steps=4,
                         guard=Guard(max_in_walls=1.0, check_domain=False))
    assert r["steps"] == 4 and r["stable"] and r["steps_to_failure"] is None
    assert len(r["curves"]["rollout_mm"]) == 4 == len(r["curves"]["in_walls"])
    # the ground truth's own numbers are the metrics of its frame 4
    x4 = traj.position[4].astype(float)
    assert r["purity_true"] == pytest.approx(M.neighbour_purity(x4, traj.phase, 0.1))
    floor = traj.attrs["domain_min"][1]
    assert r["com_height_true"] == pytest.approx(
        M.phase_heights(x4, traj.phase, len(traj.phases)) - floor)
    # a rollout error never exceeds the matched position error (nearest <= matched)
    assert all(a <= b + 1e-9 for a, b in zip(r["curves"]["rollout_mm"], r["curves"]["position_mm"]))
    assert r["err_n1_mm"] < r["err_n2_mm"]
    json.dumps(r)  # plain JSON types only


def test_score_trajectory_from_a_later_frame():
    """--start-frame: the rollout starts from ground-truth frame s0 and is compared with
    frames s0 + k; its first step is the network's n+1 prediction from frame s0."""
    traj = Dataset(SAMPLE)["random_200000_2d"]
    net = zero_net()
    guard = Guard(max_in_walls=1.0, check_domain=False)
    r = score_trajectory(net, traj, stride=10, steps=3, guard=guard, contact=False,
                         start_frame=20)
    assert r["start_frame"] == 20 and r["steps"] == 3
    x23 = traj.position[23].astype(float)
    assert r["com_height_true"] == pytest.approx(
        M.phase_heights(x23, traj.phase, len(traj.phases)) - traj.attrs["domain_min"][1])
    # step 1 of a zero network from frame 20 is ballistic (as in the n+1 test above)
    x, v = traj.position[20].astype(float), traj.velocity[20].astype(float)
    x1 = x + DT * v + 0.5 * DT * DT * traj.gravity
    ref = 1e3 * np.linalg.norm(x1 - traj.position[21], axis=1).mean()
    assert r["curves"]["position_mm"][0] == pytest.approx(ref, rel=1e-3)
    assert r["curves"]["time"][0] == pytest.approx(float(traj.time[21]))
    # the n+1 / n+2 errors do not depend on where the rollout starts
    r0 = score_trajectory(net, traj, stride=10, steps=3, guard=guard, contact=False)
    assert r["err_n1_mm"] == r0["err_n1_mm"] and r["err_n2_mm"] == r0["err_n2_mm"]
    assert r["com_height_true"] != r0["com_height_true"]
    with pytest.raises(DcdcError, match="start frame"):
        score_trajectory(net, traj, steps=3, start_frame=traj.n_frames - 1)


def test_aggregate():
    rows = [{"err_n1_mm": 1.0, "rollout_mm": None, "order_ok": True, "order_ok_true": True,
             "layers_ok": True, "stable": True, "steps": 10},
            {"err_n1_mm": 3.0, "rollout_mm": 4.0, "order_ok": False, "order_ok_true": True,
             "layers_ok": False, "stable": False, "steps": 6}]
    a = aggregate(rows)
    assert a["err_n1_mm"] == 2.0 and a["rollout_mm"] == 4.0 and a["w2_mm"] is None
    assert a["order_ok"] == 0.5 and a["stable"] == 1 and a["steps_min"] == 6
    assert a["layers_ok"] == 0.5


@pytest.fixture(scope="module")
def ckpts(tmp_path_factory):
    d = tmp_path_factory.mktemp("ck")
    torch.manual_seed(0)
    save_checkpoint(d / "trained.pt", build_network("dcdc", 2))
    save_checkpoint(d / "zero.pt", zero_net())
    save_checkpoint(d / "m3.pt", build_network("cconv", 3))
    return d


def test_evaluate_cli_two_models_json_and_plots(ckpts, tmp_path, capsys):
    js, plots = tmp_path / "e.json", tmp_path / "plots"
    args = ["evaluate", "--model", str(ckpts / "trained.pt"), "--model", str(ckpts / "zero.pt"),
            "--data", SAMPLE, "--trajectory", "random_200001_2d", "--steps", "3",
            "--max-in-walls", "1", "--json", str(js), "--plots", str(plots)]
    code, out, err = _cli(args, capsys)
    assert code == 0, err
    assert "| random_200001_2d | trained |" in out and "| random_200001_2d | zero |" in out
    assert "SPH (truth)" in out and "**all**" in out
    res = json.loads(js.read_text())
    assert set(res["trajectories"]["random_200001_2d"]) == {"trained", "zero"}
    assert set(res["aggregate"]) == {"trained", "zero"}
    assert (plots / "random_200001_2d.png").stat().st_size > 1000
    code, _, err = _cli(args, capsys)  # the JSON exists now
    assert code == 2 and "--overwrite" in err


def test_evaluate_cli_refuses_a_mismatched_model_before_work(ckpts, tmp_path, capsys):
    code, out, err = _cli(["evaluate", "--model", str(ckpts / "m3.pt"), "--data", SAMPLE,
                           "--json", str(tmp_path / "e.json")], capsys)
    assert code == 2 and err.startswith("error:") and "3-D" in err and err.count("\n") == 1
    assert not (tmp_path / "e.json").exists()


def test_evaluate_cli_start_frame(ckpts, tmp_path, capsys):
    js = tmp_path / "e.json"
    base = ["evaluate", "--model", str(ckpts / "zero.pt"), "--data", SAMPLE, "--trajectory",
            "random_200001_2d", "--steps", "2", "--max-in-walls", "1"]
    code, _, err = _cli(base + ["--start-frame", "10", "--json", str(js)], capsys)
    assert code == 0, err
    res = json.loads(js.read_text())
    assert res["start_frame"] == 10
    assert res["trajectories"]["random_200001_2d"]["zero"]["start_frame"] == 10
    code, _, err = _cli(base + ["--start-frame", "100000"], capsys)
    assert code == 2 and err.startswith("error:") and "--start-frame" in err
    assert err.count("\n") == 1


def test_perturbed_start_displaces_the_fluid_by_the_rms_asked():
    traj = Dataset(SAMPLE)["random_200001_2d"]
    a, b = perturbed_start(traj, 5, 1e-4, 1), perturbed_start(traj, 5, 1e-4, 1)
    d = a.x - traj.position[5]
    assert np.sqrt(np.mean(d ** 2)) == pytest.approx(1e-4, rel=0.1)
    np.testing.assert_array_equal(a.x, b.x)  # seeded
    assert not np.array_equal(a.x, perturbed_start(traj, 5, 1e-4, 2).x)
    np.testing.assert_array_equal(a.wall_x, traj.wall_x)
    np.testing.assert_array_equal(a.v, traj.velocity[5])
    np.testing.assert_array_equal(perturbed_start(traj, 5, 0.0, 1).x, traj.position[5])


def test_score_members_member_zero_is_the_plain_rollout_and_members_are_reproducible():
    """Member 0 is :func:`score_trajectory`'s row; with no displacement every member repeats
    it exactly (the rollout is deterministic), with one the members differ."""
    torch.manual_seed(0)
    net = build_network("dcdc", 2)
    traj = Dataset(SAMPLE)["random_200001_2d"]
    kw = dict(stride=20, steps=6, guard=Guard(max_in_walls=1.0, check_domain=False))
    plain = score_trajectory(net, traj, **kw)
    same = score_members(net, traj, 3, 0.0, **kw)
    assert same["com_height_error"] == plain["com_height_error"]
    assert same["err_n2_mm"] == plain["err_n2_mm"]
    m = same["members"]
    assert m["n"] == 3 and len(m["rollout_mm"]) == 3 and m["stable"] == [True] * 3
    assert m["com_height_error"] == [plain["com_height_error"]] * 3
    assert m["com_height_error_min"] == m["com_height_error_max"] == plain["com_height_error"]
    moved = score_members(net, traj, 3, 1e-3, **kw)["members"]
    assert moved["com_height_error"][0] == plain["com_height_error"]
    assert len(set(moved["rollout_mm"])) == 3
    assert (moved["com_height_error_min"] <= moved["com_height_error_mean"]
            <= moved["com_height_error_max"])
    assert "members" not in score_members(net, traj, 1, **kw)
    with pytest.raises(DcdcError, match="members"):
        score_members(net, traj, 0, **kw)


def test_evaluate_cli_members(ckpts, tmp_path, capsys):
    js = tmp_path / "e.json"
    base = ["evaluate", "--model", str(ckpts / "trained.pt"), "--data", SAMPLE, "--trajectory",
            "random_200001_2d", "--steps", "2", "--max-in-walls", "1", "--stride", "20"]
    code, out, err = _cli(base + ["--members", "2", "--perturb", "1e-5", "--json", str(js)], capsys)
    assert code == 0, err
    assert "COM err, members" in out
    res = json.loads(js.read_text())
    assert res["members"] == 2 and res["perturb_m"] == 1e-5
    assert res["trajectories"]["random_200001_2d"]["trained"]["members"]["n"] == 2
    for bad, word in ((["--members", "0"], "--members"), (["--perturb", "-1"], "--perturb")):
        code, _, err = _cli(base + bad, capsys)
        assert code == 2 and err.startswith("error:") and word in err and err.count("\n") == 1


@pytest.mark.slow
def test_train_simulate_evaluate_end_to_end(tmp_path, capsys):
    """End to end: the tiny training config, then `simulate` and `evaluate` with its model."""
    from pathlib import Path
    tiny = Path(__file__).resolve().parents[1] / "examples" / "train_2d_tiny.toml"
    if not tiny.exists():
        pytest.skip("examples/train_2d_tiny.toml not present")
    run_dir = tmp_path / "run"
    code, _, err = _cli(["train", str(tiny), "--out", str(run_dir), "--set", "optim.steps=4",
                         "--set", "eval.every=2", "--set", "log.checkpoint_every=2"], capsys)
    assert code == 0, err
    model = run_dir / "model.pt"
    code, out, err = _cli(["simulate", "--model", str(model), "--dataset", SAMPLE, "--trajectory",
                           "hourglass_2d", "--steps", "2", "--max-in-walls", "1", "--out",
                           str(tmp_path / "r.h5")], capsys)
    assert code == 0, err
    assert Dataset(tmp_path / "r.h5")["hourglass_2d"].n_frames == 3
    code, out, err = _cli(["evaluate", "--model", str(model), "--data", SAMPLE, "--trajectory",
                           "hourglass_2d", "--steps", "2", "--max-in-walls", "1", "--json",
                           str(tmp_path / "e.json")], capsys)
    assert code == 0, err
    row = json.loads((tmp_path / "e.json").read_text())["trajectories"]["hourglass_2d"]["model"]
    assert row["steps"] == 2 and row["err_n1_mm"] > 0
