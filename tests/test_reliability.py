"""Faults of the machine and of the user's inputs that reach the writers: a full disk, two
trainings into one run directory, inputs that would fail only after the expensive work,
and inputs that would otherwise end in a traceback or a silently wrong result.

Each case runs the real CLI in-process (``dcdc.cli.main``), so a traceback fails it.
"""
import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import assert_error_last_line, dcdc, tank_toml

from dcdc.data.dataset import Dataset

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "data/sample/test2d"
TRAJ = SAMPLE / "hourglass_2d.h5"
MODEL = ROOT / "dcdc/assets/models/dcdc2d.pt"
TINY = ROOT / "examples/train_2d_tiny.toml"


def leftovers(folder: Path) -> list[str]:
    """Temporary files and folders (``.NAME.tmp-PID``) anywhere under ``folder``."""
    return [str(p) for p in folder.rglob("*") if ".tmp-" in p.name]


# ------------------------------------------------------------------ full disk
def _disk_full(*_):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


FULL_DISK = {  # command -> (argv with {o} for the output folder, the output named in the error)
    "generate": (["generate", "lock_exchange", "--dim", "2", "--simulator", "ballistic",
                  "--duration", "0.1", "--no-progress", "-o", "{o}/ds"], "lock_exchange_2d.h5"),
    "simulate": (["simulate", "--model", MODEL, "--scene", "lock_exchange", "--steps", "2",
                  "--out", "{o}/x.h5"], "x.h5"),
    "render": (["render", TRAJ, "-o", "{o}/a.gif", "--width", "64", "--frames", "0:3",
                "--no-progress"], "a.gif"),
    "export": (["export", TRAJ, "--format", "ply", "-o", "{o}/ply", "--frames", "0:2",
                "--no-progress"], "ply"),
    "view": (["view", TRAJ, "--html", "{o}/v.html", "--max-frames", "3"], "v.html"),
    "scene copy": (["scene", "copy", "lock_exchange", "{o}/s.toml"], "s.toml"),
    "dataset merge": (["dataset", "merge", "{o}/m.h5", SAMPLE], "m.h5"),
    "train": (["train", TINY, "--set", "optim.steps=1", "--no-progress", "--out", "{o}/run"],
              "config.toml"),
}


@pytest.mark.parametrize("command", sorted(FULL_DISK))
def test_full_disk_is_one_line_and_leaves_nothing(tmp_path, capsys, monkeypatch, command):
    """The device refuses the data when it is flushed: one line naming the output, no
    temporary file, no output that looks finished."""
    monkeypatch.setattr("dcdc.outputs._sync", _disk_full)
    argv, name = FULL_DISK[command]
    out = tmp_path / "out"
    out.mkdir()
    code, _, err = dcdc(capsys, *[str(a).format(o=out) for a in argv])
    assert_error_last_line(code, err, "cannot write", name, "no space left")
    assert leftovers(out) == []
    finished = [p for p in out.rglob("*") if p.is_file() and p.name != ".lock"]
    assert finished == [], finished
    if command == "train":  # the run directory this command created is gone again
        assert not (out / "run").exists()


def test_full_disk_checked_before_writing_an_hdf5_file(tmp_path, capsys, monkeypatch):
    """An HDF5 image larger than the free space is refused with the sizes."""
    monkeypatch.setattr("dcdc.outputs.shutil.disk_usage",
                        lambda p: shutil._ntuple_diskusage(10**9, 10**9 - 1000, 1000))
    code, _, err = dcdc(capsys, "dataset", "merge", tmp_path / "m.h5", SAMPLE)
    assert_error_last_line(code, err, "m.h5", "MiB, the device has 0.0 MiB free")
    assert list(tmp_path.iterdir()) == []


def _tmpfs_shell(folder: Path, script: str, size: str = "300k") -> subprocess.CompletedProcess:
    """Run ``script`` (sh) with a ``size`` tmpfs mounted at $T = ``folder``, as an
    unprivileged user namespace allows; skip where it does not."""
    probe = subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs tmpfs /mnt"],
                           capture_output=True) if shutil.which("unshare") else None
    if probe is None or probe.returncode != 0:
        pytest.skip("no mount namespace for a small tmpfs here")
    env = {**os.environ, "DCDC": f"{sys.executable} -m dcdc.cli", "NUMBA_NUM_THREADS": "1",
           "OMP_NUM_THREADS": "1"}
    return subprocess.run(
        ["unshare", "-rm", "sh", "-c",
         f"T={folder} && mkdir $T && mount -t tmpfs -o size={size} tmpfs $T && cd {ROOT} && "
         f"{script}; echo rc=$?; ls -A $T"],
        capture_output=True, text=True, env=env, timeout=300)


@pytest.mark.slow
def test_real_full_disk_generate(tmp_path):
    """A dataset larger than a 300 kB file system: HDF5 never writes to the disk itself, so
    the run ends in one error line (HDF5 writing in place crashes in its clean-up) and
    leaves only the empty output folder."""
    r = _tmpfs_shell(tmp_path / "T", "$DCDC generate lock_exchange --dim 2 --simulator ballistic "
                     "--no-progress -o $T/out && ls -A $T/out")
    lines = r.stdout.strip().splitlines()
    assert "rc=2" in lines, r.stdout + r.stderr
    err = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("error: cannot write "), r.stderr
    assert "no space left" in err[0] or "the device has" in err[0], r.stderr
    assert lines[-1] == "out", r.stdout  # $T holds the (empty) dataset folder only


# ------------------------------------------------------------------ one run, one trainer
def test_second_training_into_one_run_is_refused(tmp_path, capsys):
    from dcdc.outputs import run_lock
    run = tmp_path / "run"
    with run_lock(run, "dcdc train"):
        code, _, err = dcdc(capsys, "train", TINY, "--set", "optim.steps=1", "--no-progress",
                            "--out", run)
        assert_error_last_line(code, err, f"{run} is in use by another dcdc train "
                                         f"(pid {os.getpid()})")
        assert [p.name for p in run.iterdir()] == [".lock"]
    # released when the holder is done: the run goes ahead
    code, out, err = dcdc(capsys, "train", TINY, "--set", "optim.steps=1", "--no-progress",
                          "--out", run)
    assert code == 0, err
    assert (run / "model.pt").exists()


def test_lock_is_released_when_its_process_dies(tmp_path):
    """flock: a killed trainer leaves no stale lock behind."""
    from dcdc.outputs import run_lock
    run = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c",
                               "import sys, time; from dcdc.outputs import run_lock\n"
                               f"with run_lock({str(run)!r}, 'dcdc train'):\n"
                               "    print('held', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        from dcdc.errors import DcdcError
        with pytest.raises(DcdcError, match=f"pid {holder.pid}"):
            with run_lock(run, "dcdc train"):
                pass
    finally:
        holder.kill()
        holder.wait()
    with run_lock(run, "dcdc train"):
        pass


# ------------------------------------------------------------------ checked before the work
def scene(tmp_path, name="tank", radius=0.025, seed=0) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(tank_toml(name=name, radius=radius, seed=seed, duration=0.1))
    return p


@pytest.mark.parametrize("kwargs, words", [
    ({"seed": 99999999999999999999}, ["seed must be an integer from 0 to 2^63 - 1"]),
    ({"seed": -1}, ["seed must be an integer from 0 to 2^63 - 1"]),
    ({"name": "a" * 5000}, ["name is 5000 characters long; at most 200"]),
    ({"radius": 5e-324}, ["particles", "over the limit"]),
])
def test_scene_values_that_failed_after_the_work(tmp_path, capsys, kwargs, words):
    f = scene(tmp_path, **kwargs)
    code, _, err = dcdc(capsys, "scene", "show", f)
    assert_error_last_line(code, err, *words)
    out = tmp_path / "ds"
    code, _, err = dcdc(capsys, "generate", f, "--simulator", "ballistic", "--no-progress",
                        "-o", out)
    assert_error_last_line(code, err, *words)
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("argv", [
    ["scene", "random", "--seed", "-1"],
    ["generate", "--random", "1", "--seed", "99999999999999999999", "-o", "{o}/ds"],
])
def test_seed_options_are_bounded(tmp_path, capsys, argv):
    code, _, err = dcdc(capsys, *[a.format(o=tmp_path) for a in argv])
    assert_error_last_line(code, err, "--seed", "0<=x<=9223372036854775807")
    assert not (tmp_path / "ds").exists()


@pytest.mark.parametrize("argv", [
    ["validate-sph", "--quick", "--case", "hydrostatic", "--json", "{o}/afile/v.json"],
    ["benchmark", "cconv", "--json", "{o}/afile/sub/c.json"],
])
def test_report_file_checked_before_the_work(tmp_path, capsys, argv):
    """The message is the output check's: the work (minutes) never ran."""
    (tmp_path / "afile").write_text("x")
    code, out, err = dcdc(capsys, *[a.format(o=tmp_path) for a in argv])
    assert_error_last_line(code, err, "afile", "is a file")
    assert out == ""


# ------------------------------------------------------------------ no traceback
def test_nesting_too_deep_to_read(tmp_path, capsys):
    deep = "[" * 100_000 + "]" * 100_000
    (tmp_path / "deep.toml").write_text(f'name = "a"\ndim = 2\nx = {deep}\n')
    code, _, err = dcdc(capsys, "scene", "show", tmp_path / "deep.toml")
    assert_error_last_line(code, err, "deep.toml", "nested too deeply")
    (tmp_path / "deep.json").write_text(deep)
    code, _, err = dcdc(capsys, "scene", "import", tmp_path / "deep.json", "-o",
                        tmp_path / "d.toml")
    assert_error_last_line(code, err, "deep.json", "nested too deeply")
    (tmp_path / "cfg.toml").write_text(f"x = {deep}\n")
    code, _, err = dcdc(capsys, "train", tmp_path / "cfg.toml", "--out", tmp_path / "run")
    assert_error_last_line(code, err, "cfg.toml", "nested too deeply")
    assert not (tmp_path / "run").exists()


@pytest.fixture
def bad_trajs(tmp_path):
    """Copies of a sample trajectory: NaN in one frame, all inf, no frames, flat positions."""
    import h5py
    out = {}
    for kind in ("nan", "inf", "zero", "flat"):
        p = tmp_path / f"{kind}.h5"
        shutil.copy(TRAJ, p)
        with h5py.File(p, "r+") as f:
            g = f["hourglass_2d"]
            x = g["position"][()]
            if kind == "nan":
                g["position"][3, :5] = np.nan
            else:
                arrays = {"inf": {"position": np.full_like(x, np.inf)},
                          "zero": {k: g[k][()][:0] for k in ("position", "velocity", "time")},
                          "flat": {"position": x.reshape(len(x), -1)}}[kind]
                for k, a in arrays.items():
                    del g[k]
                    g.create_dataset(k, data=a)
        out[kind] = p
    return out


VIEWERS = {
    "render": ["render", "{t}", "-o", "{o}/a.gif", "--width", "64", "--no-progress"],
    "view": ["view", "{t}", "--html", "{o}/v.html"],
    "export": ["export", "{t}", "--format", "ply", "-o", "{o}/ply", "--no-progress"],
}


@pytest.mark.parametrize("kind, words", [
    ("zero", ["holds no frames"]),
    ("inf", ["holds no finite position"]),
    ("flat", ["position has shape [51, {2n}], not [frames, particles, 2]"]),
])
@pytest.mark.parametrize("command", sorted(VIEWERS))
def test_unusable_trajectory_is_one_line(tmp_path, capsys, bad_trajs, command, kind, words):
    out = tmp_path / "out"
    out.mkdir()
    argv = [a.format(t=bad_trajs[kind], o=out) for a in VIEWERS[command]]
    code, _, err = dcdc(capsys, *argv)
    n = Dataset(TRAJ)["hourglass_2d"].n_particles
    assert_error_last_line(code, err, f"{kind}.h5", *(w.replace("{2n}", str(2 * n)) for w in words))
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("command", sorted(VIEWERS))
def test_non_finite_positions_are_reported(tmp_path, capsys, bad_trajs, command):
    argv = [a.format(t=bad_trajs["nan"], o=tmp_path) for a in VIEWERS[command]]
    code, _, err = dcdc(capsys, *argv)
    assert code == 0, err
    assert err.splitlines()[0] == (f"note: {bad_trajs['nan']}: trajectory hourglass_2d has 5 "
                                   f"non-finite particle positions in 1 of 51 frames, from "
                                   f"frame 3 (the run that wrote it diverged?)")


@pytest.mark.parametrize("args, words", [
    (["--fps", "nan"], ["--fps", "got nan"]),
    (["--width", "200000"], ["200000 x", "at most 16384 pixels a side"]),
    (["--supersample", "1000"], ["--supersample must be from 1 to 16"]),
])
def test_render_sizes_are_bounded(tmp_path, capsys, args, words):
    out = tmp_path / "a.gif"
    code, _, err = dcdc(capsys, "render", TRAJ, "-o", out, "--no-progress", *args)
    assert_error_last_line(code, err, *words)
    assert list(tmp_path.iterdir()) == []


def test_canvas_over_half_the_memory_is_refused(monkeypatch):
    from dcdc.errors import DcdcError
    from dcdc.render.frames import check_canvas
    monkeypatch.setattr("dcdc.scene.budget.physical_memory", lambda: 2.0**30)
    check_canvas(800, 600, 2)
    with pytest.raises(DcdcError, match="needs 1.4 GiB, more than half of this machine's 1.0"):
        check_canvas(4000, 2000, 2)


@pytest.mark.parametrize("command", [["scene", "show", "lock_exchange"],
                                     ["scene", "random", "--seed", "1"]])
def test_unknown_picture_format(tmp_path, capsys, command):
    code, out, err = dcdc(capsys, *command, "--image", tmp_path / "x.bmpx")
    assert_error_last_line(code, err, "x.bmpx", "unknown picture format '.bmpx'", ".png")
    assert out == "" and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("device, words", [
    ("tpu9", ["--device must be cpu or cuda (got 'tpu9')"]),
    ("meta", ["--device must be cpu or cuda (got 'meta')"]),
    ("cuda", ["--device cuda"]),
])
def test_simulate_device_checked_like_train(tmp_path, capsys, device, words):
    import torch
    if device == "cuda" and torch.cuda.is_available():
        pytest.skip("CUDA is available here")
    code, _, err = dcdc(capsys, "simulate", "--model", MODEL, "--scene", "lock_exchange",
                        "--steps", "2", "--device", device, "--out", tmp_path / "x.h5")
    assert_error_last_line(code, err, *words)
    assert list(tmp_path.iterdir()) == []


def test_output_folder_that_is_a_symlink_loop(tmp_path, capsys):
    loop = tmp_path / "L"
    loop.symlink_to(loop)
    code, _, err = dcdc(capsys, "generate", "lock_exchange", "--simulator", "ballistic",
                        "-o", loop)
    assert_error_last_line(code, err, "symbolic link", "leads nowhere")


# ------------------------------------------------------------------ no silent wrong result
def test_mesh_with_a_nan_vertex_is_refused(tmp_path, capsys):
    shutil.copy(ROOT / "examples/my_scene.toml", tmp_path / "s.toml")
    lines = (ROOT / "examples/pillar.obj").read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("v "))
    lines[k] = "v nan 0.0 0.1"
    (tmp_path / "pillar.obj").write_text("\n".join(lines) + "\n")
    code, _, err = dcdc(capsys, "scene", "show", tmp_path / "s.toml")
    assert_error_last_line(code, err, "pillar.obj", "1 vertex(es)", "not a finite number")


@pytest.mark.parametrize("argv", [
    ["scene", "show", "lock_exchange", "--max-particles", "nan"],
    ["generate", "lock_exchange", "--simulator", "ballistic", "--max-particles", "nan",
     "-o", "{o}/ds"],
    ["simulate", "--model", MODEL, "--scene", "lock_exchange", "--steps", "2",
     "--max-particles", "nan", "--out", "{o}/x.h5"],
])
def test_nan_particle_budget_is_refused(tmp_path, capsys, argv):
    code, _, err = dcdc(capsys, *[str(a).format(o=tmp_path) for a in argv])
    assert_error_last_line(code, err, "--max-particles must be a number > 0")
    assert list(tmp_path.iterdir()) == []


def test_nan_particle_budget_from_the_environment(capsys, monkeypatch):
    monkeypatch.setenv("DCDC_MAX_PARTICLES", "nan")
    code, _, err = dcdc(capsys, "scene", "show", "lock_exchange")
    assert_error_last_line(code, err, "DCDC_MAX_PARTICLES must be a number > 0")


def test_sph_settings_checked_with_the_ballistic_simulator(tmp_path, capsys):
    code, _, err = dcdc(capsys, "generate", "lock_exchange", "--simulator", "ballistic",
                        "--sph", "cfl=abc", "-o", tmp_path / "ds")
    assert_error_last_line(code, err, "sph.cfl must be a float")
    assert not (tmp_path / "ds").exists()


# ------------------------------------------------------------------ messages
@pytest.mark.parametrize("argv, words", [
    (["generate", "--bogus"], ["No such option '--bogus'", "(see 'dcdc generate --help')"]),
    (["render"], ["Missing option", "(see 'dcdc render --help')"]),
    (["nosuch"], ["No such command 'nosuch'", "(see 'dcdc --help')"]),
    (["scene", "show", "lock_exchange", "--dim", "7"], ["'--dim'", "7 is not in the range"]),
])
def test_usage_errors_are_one_line(capsys, argv, words):
    code, out, err = dcdc(capsys, *argv)
    assert_error_last_line(code, err, *words)
    assert len(err.strip().splitlines()) == 1 and "Usage:" not in err and out == ""


def test_a_group_without_its_command_shows_its_help(capsys):
    code, out, err = dcdc(capsys, "scene")
    assert out.startswith("Usage: dcdc scene") and "random" in out and err == ""


def test_fluid_far_outside_the_domain_is_called_that(tmp_path, capsys):
    f = scene(tmp_path)
    f.write_text(f.read_text().replace("min = [0.1, 0.1]\nmax = [0.5, 0.5]",
                                       "min = [5.1, 5.1]\nmax = [5.5, 5.5]"))
    code, _, err = dcdc(capsys, "scene", "show", f)
    assert_error_last_line(code, err, "fluid[0]", "outside the domain")


EMITTER_AFTER_THE_END = """
[[emitter]]
phase = "water"
position = [0.7, 0.8]
direction = [0.0, -1.0]
speed = 1.0
rate = 100.0
start = 0.4
stop = 0.6
"""


@pytest.mark.parametrize("edit, words", [
    (lambda text: text.replace("duration = 0.1", "duration = 0.01"), ["shorter than one frame"]),
    (lambda text: text + EMITTER_AFTER_THE_END, ["emitter[0] starts at 0.4 s"]),
])
def test_scene_show_refuses_what_generate_refuses(tmp_path, capsys, edit, words):
    f = scene(tmp_path)
    f.write_text(edit(f.read_text()))
    for argv in (["scene", "show", f],
                 ["generate", f, "--simulator", "ballistic", "-o", tmp_path / "ds"]):
        code, _, err = dcdc(capsys, *argv)
        assert_error_last_line(code, err, *words)


def test_file_held_by_a_writer_is_not_called_corrupt(tmp_path, capsys):
    p = tmp_path / "held.h5"
    shutil.copy(TRAJ, p)
    holder = subprocess.Popen([sys.executable, "-c",
                               f"import h5py, time; f = h5py.File({str(p)!r}, 'r+'); "
                               "print('open', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "open"
        code, _, err = dcdc(capsys, "dataset", "info", p)
    finally:
        holder.kill()
        holder.wait()
    if "unable to lock" in err or code == 0:
        pytest.skip("HDF5 file locking is off here")
    assert_error_last_line(code, err, "another process has it open for writing")
    assert "corrupt" not in err


def test_file_without_trajectory_groups(tmp_path, capsys):
    import h5py
    with h5py.File(tmp_path / "x.h5", "w") as f:
        for i in range(9):
            f.create_dataset(f"d{i}", data=np.zeros(3))
    code, _, err = dcdc(capsys, "dataset", "info", tmp_path / "x.h5")
    assert_error_last_line(code, err, "not a dcdc dataset", "d0, d1, d2, …",
                          "not trajectory groups")


def test_mesh_with_huge_coordinates_is_named_so(tmp_path, capsys):
    from dcdc.errors import DcdcError
    from dcdc.geometry.mesh import load_mesh
    lines = []
    for ln in (ROOT / "tests/data/models/UnitBox.obj").read_text().splitlines():
        if ln.startswith("v "):
            ln = "v " + " ".join(repr(float(t) * 1e30) for t in ln.split()[1:4])
        lines.append(ln)
    (tmp_path / "big.obj").write_text("\n".join(lines) + "\n")
    with pytest.raises(DcdcError, match="coordinates reach 5e\\+29, beyond the 1e\\+09"):
        load_mesh(tmp_path / "big.obj")


def test_merge_into_a_folder_on_a_full_disk_leaves_no_folder(tmp_path, capsys, monkeypatch):
    """The merged folder appears whole or not at all (it is renamed into place)."""
    monkeypatch.setattr(shutil, "copyfile", _disk_full)
    out = tmp_path / "merged"
    code, _, err = dcdc(capsys, "dataset", "merge", out, SAMPLE)
    assert_error_last_line(code, err, f"cannot write {out}: no space left")
    assert list(tmp_path.iterdir()) == []


def test_disk_full_names_the_output_not_its_temporary_name(tmp_path, monkeypatch):
    from dcdc.errors import DcdcError
    from dcdc.outputs import atomic_dir, write_bytes
    monkeypatch.setattr("dcdc.outputs.shutil.disk_usage",
                        lambda p: shutil._ntuple_diskusage(10**9, 10**9 - 10, 10))
    with pytest.raises(DcdcError) as e:
        with atomic_dir(tmp_path / "run") as tmp:
            write_bytes(tmp / "a.h5", b"x" * 100)
    assert str(e.value) == (f"cannot write {tmp_path / 'run' / 'a.h5'}: it needs 0.0 MiB, the "
                            f"device has 0.0 MiB free")
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ Ctrl-C in set-up
def test_first_signal_stops_set_up_at_once():
    """Set-up code (building a large scene) has no safe point for minutes: inside
    interrupt.at_once the first Ctrl-C raises there and then, through ``except Exception``
    clauses of the code it lands in."""
    import signal
    import time

    from dcdc.data import interrupt
    from dcdc.errors import Interrupted
    reached = []
    with pytest.raises(Interrupted) as e:
        with interrupt.handling(), interrupt.at_once():
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(5)
                reached.append("after")
            except Exception:  # a library's own error handling does not take it
                reached.append("swallowed")
    assert e.value.exit_code == 130 and reached == []
    # outside at_once the first signal waits for a safe point, as before
    with pytest.raises(Interrupted):
        with interrupt.handling():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
            reached.append("safe point")
            interrupt.check()
    assert reached == ["safe point"]


def test_training_on_a_diverged_trajectory_names_it(tmp_path, capsys):
    import h5py
    data = tmp_path / "train"
    shutil.copytree(ROOT / "data/sample/train2d", data)
    bad = sorted(data.glob("*.h5"))
    for p in bad:
        with h5py.File(p, "r+") as f:
            for name in f:
                x = f[name]["position"][()]
                x[:, 0] = np.nan
                f[name]["position"][...] = x
    code, _, err = dcdc(capsys, "train", TINY, "--set", f"data.train={str(data)!r}",
                        "--set", "optim.steps=1", "--no-progress", "--out", tmp_path / "run")
    assert_error_last_line(code, err, str(data), "non-finite positions", "frame",
                          "a diverged run")


def test_full_disk_while_saving_a_checkpoint_is_one_error(tmp_path, monkeypatch):
    """A checkpoint is serialised in memory and written through the one writer path: a
    device that refuses it gives a DcdcError naming the file and leaves no temporary file."""
    from dcdc.errors import DcdcError
    from dcdc.model.checkpoint import save_checkpoint
    from dcdc.model.networks import build_network

    monkeypatch.setattr("dcdc.outputs._sync", _disk_full)
    with pytest.raises(DcdcError, match="cannot write.*m.pt.*no space left"):
        save_checkpoint(tmp_path / "m.pt", build_network("cconv", 2))
    assert list(tmp_path.iterdir()) == []
