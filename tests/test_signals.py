"""Runaway jobs: real signals sent to real ``dcdc`` processes.

``dcdc generate --workers 2`` on a tiny ballistic dataset (slowed by DCDC_BALLISTIC_DELAY so
signals land mid-run): SIGKILL of the parent leaves no worker behind and no new file
appears afterwards; SIGTERM and Ctrl-C (SIGINT to the process group, as a terminal sends it)
stop the run with exit 143 / 130, no traceback, only complete trajectories on disk, no
temporary files, and the same command then resumes to the full set. Ctrl-C during
``dcdc demo`` (the real SPH solver) ends in "aborted", exit 130, and leaves the previous
output folder untouched.
"""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dcdc.data import Dataset

ROOT = Path(__file__).resolve().parents[1]
N_JOBS = 6


def start(args, **env):
    return subprocess.Popen([sys.executable, "-m", "dcdc.cli", *map(str, args)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, **env), start_new_session=True)


def generate_args(out):
    return ["generate", "--random", N_JOBS, "--seed", 0, "--dim", 2, "--max-ratio", 4,
            "--duration", 0.4, "--simulator", "ballistic", "--workers", 2, "--no-progress", "-o", out]


def children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")  # a zombie has exited (nobody reaped it yet)


def wait_for(cond, timeout=60.0):
    t0 = time.time()
    while not cond():
        if time.time() - t0 > timeout:
            raise AssertionError("timed out")
        time.sleep(0.05)


def started_generate(out):
    """A running `dcdc generate --workers 2` with its first trajectory written."""
    p = start(generate_args(out), DCDC_BALLISTIC_DELAY="0.03")  # ~0.6 s per trajectory
    wait_for(lambda: len(list(out.glob("random_*.h5"))) >= 1 or p.poll() is not None)
    assert p.poll() is None, p.communicate()
    workers = [c for c in children(p.pid) if _is_worker(c)]
    return p, workers


def _cmdline(pid):
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace")
    except OSError:
        return ""


def _is_worker(pid):
    return "multiprocessing" in _cmdline(pid) and "resource_tracker" not in _cmdline(pid)


pytestmark = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")


@pytest.mark.slow
def test_sigkill_of_parent_stops_workers(tmp_path):
    out = tmp_path / "ds"
    p, workers = started_generate(out)
    assert len(workers) == 2
    p.kill()
    p.wait()
    wait_for(lambda: not any(alive(w) for w in workers), timeout=10)
    n = len(list(out.glob("random_*.h5")))
    time.sleep(1.0)  # a surviving worker would go on writing the remaining jobs
    assert len(list(out.glob("random_*.h5"))) == n < N_JOBS
    assert len(Dataset(out)) == n  # every file there is a complete trajectory


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, word", [(signal.SIGTERM, 143, "terminated"),
                                             (signal.SIGINT, 130, "aborted")])
def test_sigterm_and_ctrl_c_stop_cleanly_then_resume(tmp_path, sig, code, word):
    out = tmp_path / "ds"
    p, workers = started_generate(out)
    if sig == signal.SIGINT:
        os.killpg(p.pid, sig)  # a terminal's Ctrl-C reaches the whole process group
    else:
        p.send_signal(sig)
    _, err = p.communicate(timeout=30)
    assert p.returncode == code, err
    assert word in err and "resume" in err and "Traceback" not in err, err
    assert not any(alive(w) for w in workers)
    done = Dataset(out)
    assert 1 <= len(done) < N_JOBS and done.incomplete == []
    assert not list(out.glob(".*tmp*"))
    r = subprocess.run([sys.executable, "-m", "dcdc.cli", *map(str, generate_args(out))], cwd=ROOT,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f"{N_JOBS - len(done)} written, {len(done)} already done" in r.stdout
    assert len(Dataset(out)) == N_JOBS


@pytest.mark.slow
def test_ctrl_c_during_demo(tmp_path):
    """An interrupted demo exits 130 with one 'aborted' line and keeps only what it finished
    (stopped inside the SPH run: nothing), with no temporary file and no demo.txt, the mark
    of a finished demo; --overwrite removed the previous run's files first, so none of them
    is mistaken for this run's."""
    out = tmp_path / "demo"
    out.mkdir()
    (out / "lock_exchange_2d.gif").write_text("previous run")
    p = start(["demo", "--scene", "lock_exchange", "--duration", "20", "--out", out, "--overwrite"])
    wait_for(lambda: not (out / "lock_exchange_2d.gif").exists() or p.poll() is not None)
    time.sleep(3.0)  # inside numba: compiling or stepping
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert err.strip().splitlines()[-1].startswith("aborted") and "Traceback" not in err, err
    assert list(out.iterdir()) == []
    assert not [f for f in tmp_path.rglob("*") if ".tmp-" in f.name]
