"""Faults of the machine and of the user's inputs that reach the writers: a full disk, two
trainings into one run directory, inputs that would fail only after the expensive work,
and inputs that used to end in a traceback or a silently wrong result.

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

from dcdc.cli import main

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "data/sample/test2d"
TRAJ = SAMPLE / "hourglass_2d.h5"
MODEL = ROOT / "dcdc/assets/models/dcdc2d.pt"
TINY = ROOT / "examples/train_2d_tiny.toml"


def dcdc(capsys, *args):
    """Run the CLI; (exit status, stdout, stderr)."""
    try:
        main([str(a) for a in args])
        code = 0
    except SystemExit as e:
        code = e.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, err, *words):
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert code == 2, err
    assert lines and lines[-1].startswith("error: "), err
    assert not any("Traceback" in ln for ln in lines), err
    for w in words:
        assert w in lines[-1], (w, lines[-1])


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
    assert_one_line_error(code, err, "cannot write", name, "no space left")
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
    assert_one_line_error(code, err, "m.h5", "MiB, the device has 0.0 MiB free")
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


def test_real_full_disk_generate(tmp_path):
    """A dataset larger than a 300 kB file system: HDF5 never writes to the disk itself, so
    the run ends in one error line (it used to crash in HDF5's clean-up) and leaves only
    the empty output folder."""
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
        assert_one_line_error(code, err, f"{run} is in use by another dcdc train "
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
