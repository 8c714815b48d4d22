"""Writers and messages found by replaying hostile inputs as a new user would: the sample
data verifiable, the LagrangeBench export and the JSON reports through the one writer path,
and a one-frame trajectory named as such."""
import errno
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from helpers import assert_error_last_line, dcdc

from dcdc.data.dataset import Dataset, write_trajectory

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "data/sample"
TRAIN, TEST = SAMPLE / "train2d", SAMPLE / "test2d"
MODEL = ROOT / "dcdc/assets/models/dcdc2d.pt"


def _disk_full(*_):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# ------------------------------------------------------------------ the sample in git
def test_sample_verifies_from_its_parent_folder(capsys):
    """`dcdc dataset info --verify data/sample` describes and checks both sets, every
    trajectory checksummed (no format-1 file left)."""
    code, out, err = dcdc(capsys, "dataset", "info", "--verify", SAMPLE)
    assert code == 0, err
    assert out.count("verify      3 checksummed and intact\n") == 2, out
    assert "format 1" not in out and "0 finished" not in out
    assert f"dataset     {TRAIN}" in out and f"dataset     {TEST}" in out


def test_parent_folder_reports_a_corrupt_trajectory_of_a_set(tmp_path, capsys):
    import h5py
    shutil.copytree(TRAIN, tmp_path / "train2d")
    shutil.copytree(TEST, tmp_path / "test2d")
    p = tmp_path / "test2d/hourglass_2d.h5"
    with h5py.File(p) as f:
        chunk = f["hourglass_2d/position"].id.get_chunk_info(10)
    with open(p, "r+b") as fh:  # other bytes over one stored chunk of positions
        fh.seek(chunk.byte_offset)
        fh.write(b"\x55" * (chunk.size // 2))
    code, out, err = dcdc(capsys, "dataset", "info", "--verify", tmp_path)
    assert_error_last_line(code, err, "1 corrupt trajectory", "hourglass_2d")
    assert "verify      2 checksummed and intact, 1 CORRUPT" in out
    assert "verify      3 checksummed and intact" in out  # the other set is still described


def test_parent_folder_as_json(capsys):
    import json
    code, out, _ = dcdc(capsys, "dataset", "info", "--json", SAMPLE)
    doc = json.loads(out)
    assert code == 0 and [d["path"] for d in doc["datasets"]] == [str(TEST), str(TRAIN)]


# ------------------------------------------------------------------ LagrangeBench export
def test_lagrangebench_export_on_a_full_disk_leaves_nothing(tmp_path, capsys, monkeypatch):
    """Its HDF5 files are built in memory and written through the writer path: a device that
    refuses them is one line naming the file, and no folder or temporary file is left."""
    import h5py
    opened = []
    real = h5py.File

    def spy(name, mode="r", *args, **kwargs):
        if mode != "r" and kwargs.get("driver") != "core":
            opened.append(str(name))
        return real(name, mode, *args, **kwargs)
    monkeypatch.setattr(h5py, "File", spy)
    monkeypatch.setattr("dcdc.outputs._sync", _disk_full)
    out = tmp_path / "2D_DCD"
    code, _, err = dcdc(capsys, "dataset", "export-lagrangebench", "--train", TRAIN, "-o", out)
    assert_error_last_line(code, err, f"cannot write {out / 'train.h5'}", "no space left")
    assert _files(tmp_path) == [] and opened == []


def test_lagrangebench_split_larger_than_memory_is_refused_before_writing(tmp_path, capsys,
                                                                          monkeypatch):
    monkeypatch.setattr("dcdc.scene.budget.physical_memory", lambda: 2.0 * 2**20)
    code, _, err = dcdc(capsys, "dataset", "export-lagrangebench", "--train", TRAIN, "-o",
                        tmp_path / "lb")
    assert_error_last_line(code, err, "the train split (3 trajectories of 51 frames",
                          "more than half of this machine's 0.0 GiB")
    assert _files(tmp_path) == []


def test_lagrangebench_split_size_is_what_is_written(tmp_path):
    from dcdc.data import lagrangebench as lb
    meta = lb.export_lagrangebench({"train": TRAIN}, tmp_path / "lb")
    n, T = meta["num_particles_max"], meta["sequence_length_train"] + 1
    size = (tmp_path / "lb/train.h5").stat().st_size
    expect = lb.split_bytes(T, meta["num_trajs_train"], n, 2)
    assert expect <= size < expect + 64 * 1024  # arrays + HDF5's headers


# ------------------------------------------------------------------ JSON reports
def _fake_validate(*args, **kwargs):
    from dcdc.sph.measures import Row
    return [Row("hydrostatic", "pressure error", 0.01, "0", "< 0.05", True)]


def _fake_sph_run(fn, repeat):
    return {"solver": "dcdc dfsph", "fluid_particles": 200, "threads": 1,
            "wall_s_per_simulated_s": 1.0, "ms_per_substep": 1.0, "mean_substep_ms": 1.0,
            "pressure_iterations_per_substep": 2.0}


REPORTS = {  # command -> (argv with {j} for the report file, what to fake)
    "validate-sph": (["validate-sph", "--quick", "--case", "hydrostatic", "--json", "{j}"],
                     ("dcdc.sph.validate.validate", _fake_validate)),
    "benchmark sph": (["benchmark", "sph", "--particles", "200", "--duration", "0.02",
                       "--ratios", "2", "--dim", "2", "--no-splishsplash", "--repeat", "1",
                       "--json", "{j}"], ("dcdc.sph.benchmark.median_run", _fake_sph_run)),
    "benchmark model": (["benchmark", "model", "--particles", "300", "--networks", "dcdc",
                         "--repeat", "1", "--json", "{j}"],
                        ("dcdc.model.benchmark.run_model", lambda *a, **k: {"scaling": {}})),
}


@pytest.mark.parametrize("command", sorted(REPORTS))
def test_json_report_on_a_full_disk_is_one_line(tmp_path, capsys, monkeypatch, command):
    argv, (target, fake) = REPORTS[command]
    monkeypatch.setattr(target, fake)
    monkeypatch.setattr("dcdc.outputs._sync", _disk_full)
    report = tmp_path / "r.json"
    code, _, err = dcdc(capsys, *[a.format(j=report) for a in argv])
    assert_error_last_line(code, err, f"cannot write {report}", "no space left")
    assert _files(tmp_path) == []


@pytest.mark.parametrize("command", sorted(REPORTS))
def test_json_report_is_written_whole(tmp_path, capsys, monkeypatch, command):
    import json
    argv, (target, fake) = REPORTS[command]
    monkeypatch.setattr(target, fake)
    report = tmp_path / "sub" / "r.json"  # a missing folder is created
    code, _, err = dcdc(capsys, *[a.format(j=report) for a in argv])
    assert code == 0, err
    assert isinstance(json.loads(report.read_text()), dict)
    assert _files(tmp_path) == ["sub", "sub/r.json"]


@pytest.mark.parametrize("command", sorted(REPORTS))
def test_json_report_path_checked_before_the_work(tmp_path, capsys, monkeypatch, command):
    argv, (target, _) = REPORTS[command]
    ran = []
    monkeypatch.setattr(target, lambda *a, **k: ran.append(1))
    (tmp_path / "afile").write_text("x")
    code, out, err = dcdc(capsys, *[a.format(j=tmp_path / "afile" / "r.json") for a in argv])
    assert_error_last_line(code, err, "afile", "is a file")
    assert ran == [] and out == ""


def test_cconv_report_goes_through_the_writer_path(tmp_path, monkeypatch):
    from dcdc.errors import DcdcError
    from dcdc.model.benchmark import _write_json
    _write_json(tmp_path / "c.json", {"a": 1})
    assert (tmp_path / "c.json").read_text() == '{\n  "a": 1\n}\n'
    monkeypatch.setattr("dcdc.outputs._sync", _disk_full)
    with pytest.raises(DcdcError, match="cannot write .*c2.json: no space left"):
        _write_json(tmp_path / "c2.json", {"a": 1})
    assert _files(tmp_path) == ["c.json"]


# ------------------------------------------------------------------ a one-frame trajectory
@pytest.fixture
def one_frame(tmp_path):
    t = Dataset(TEST)["hourglass_2d"]
    out = tmp_path / "one"
    out.mkdir()
    write_trajectory(out / "hourglass_2d.h5", "hourglass_2d", t.position[:1], t.velocity[:1],
                     t.time[:1], t.system(0), {"frame_dt": t.frame_dt, "scene": "hourglass"})
    assert Dataset(out)[0].n_frames == 1
    return out


ONE_FRAME = "trajectory hourglass_2d has one frame; a rollout needs at least two"


@pytest.mark.parametrize("argv", [
    ["simulate", "--model", MODEL, "--dataset", "{d}", "--trajectory", "hourglass_2d",
     "--out", "{o}/x.h5"],
    ["evaluate", "--model", MODEL, "--data", "{d}"],
    ["evaluate", "--model", MODEL, "--data", "{d}", "--start-frame", "3"],
])
def test_one_frame_trajectory_is_named_as_such(tmp_path, capsys, one_frame, argv):
    """The problem is the trajectory's length, not a --start-frame the user never gave."""
    out = tmp_path / "out"
    out.mkdir()
    code, _, err = dcdc(capsys, *[str(a).format(d=one_frame, o=out) for a in argv])
    assert_error_last_line(code, err, ONE_FRAME)
    assert "--start-frame" not in err or "--steps" in err
    assert list(out.iterdir()) == []


def test_one_frame_trajectory_rolls_out_with_steps(tmp_path, capsys, one_frame):
    code, out, err = dcdc(capsys, "simulate", "--model", MODEL, "--dataset", one_frame,
                          "--trajectory", "hourglass_2d", "--steps", "2", "--out", tmp_path / "x.h5")
    assert code == 0, err
    assert Dataset(tmp_path / "x.h5")[0].n_frames == 3


@pytest.mark.parametrize("argv, words", [
    (["simulate", "--model", MODEL, "--dataset", TEST, "--trajectory", "hourglass_2d",
      "--start-frame", "50", "--out", "{o}/x.h5"],
     ["--start-frame 50 is the last frame of hourglass_2d, which no frame follows",
      "frames 0..49", "--steps"]),
    (["simulate", "--model", MODEL, "--dataset", TEST, "--trajectory", "hourglass_2d",
      "--start-frame", "70", "--steps", "2", "--out", "{o}/x.h5"],
     ["--start-frame 70 is outside hourglass_2d, which has 51 frames", "frames 0..50"]),
    (["evaluate", "--model", MODEL, "--data", TEST, "--trajectory", "hourglass_2d",
      "--start-frame", "70"],
     ["--start-frame 70 is outside hourglass_2d, which has 51 frames", "frames 0..49"]),
])
def test_start_frame_messages(tmp_path, capsys, argv, words):
    code, _, err = dcdc(capsys, *[str(a).format(o=tmp_path) for a in argv])
    assert_error_last_line(code, err, *words)
    assert list(tmp_path.iterdir()) == []


def test_score_trajectory_names_a_one_frame_trajectory(one_frame):
    from dcdc.errors import DcdcError
    from dcdc.evaluate.scores import score_trajectory
    from dcdc.model.checkpoint import load_checkpoint
    net = load_checkpoint(MODEL)[0]
    with pytest.raises(DcdcError, match=ONE_FRAME):
        score_trajectory(net, Dataset(one_frame)[0])
    assert np.isfinite(Dataset(one_frame)[0].position).all()
