"""A real training process killed with SIGKILL resumes from its last checkpoint."""
import os
import signal
import subprocess
import sys
import time

import pytest

from dcdc.train.trainer import checkpoints, train
from test_train import PATHS, TINY, rows, tiny

SETTINGS = ["optim.steps=40", "log.checkpoint_every=4", "eval.every=0"]


@pytest.mark.slow
@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
def test_sigkilled_run_resumes_from_its_last_checkpoint(tmp_path):
    run = tmp_path / "run"
    sets = [a for s in PATHS + SETTINGS + ["log.tensorboard=false"] for a in ("--set", s)]
    proc = subprocess.Popen([sys.executable, "-m", "dcdc.cli", "train", str(TINY), "--out",
                             str(run), "--no-progress", *sets],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            done = [p for p in checkpoints(run) if p.name >= "step_00000008.pt"]
            if done and len(rows(run)) >= 9:
                break
            time.sleep(0.02)
        assert proc.poll() is None, proc.stdout.read().decode()[-2000:]
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    last = int(checkpoints(run)[0].stem.split("_")[1])
    logged = len(rows(run))
    assert 8 <= last < 40 and logged >= last

    msgs = []
    train(tiny(*SETTINGS), run, resume=True, echo=msgs.append)
    assert any(f"(step {last})" in m for m in msgs), msgs
    got = rows(run)
    assert [int(r["step"]) for r in got] == list(range(1, 41))  # no gap, no repeat

    ref = tmp_path / "ref"  # the same run, never interrupted
    train(tiny(*SETTINGS), ref, echo=lambda *_: None)
    for a, b in zip(rows(ref), got):
        assert float(a["loss"]) == pytest.approx(float(b["loss"]), rel=1e-4), a["step"]
