"""torchrun --nproc-per-node 2 (gloo, CPU): each rank trains on its shard of the batch and
DistributedDataParallel averages the gradients, so the run equals a single process."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from dcdc.model.checkpoint import load_checkpoint
from dcdc.train.trainer import train
from test_train import PATHS, TINY, rows, tiny

SETTINGS = ["optim.steps=4", "log.checkpoint_every=2", "eval.every=2", "data.batch_scenes=2"]


@pytest.mark.slow
def test_torchrun_two_ranks_equals_one_process(tmp_path):
    torchrun = Path(sys.executable).with_name("torchrun")
    if not torchrun.exists():
        torchrun = shutil.which("torchrun")
    run = tmp_path / "ddp"
    sets = [a for s in PATHS + SETTINGS + ["log.tensorboard=false"] for a in ("--set", s)]
    res = subprocess.run([str(torchrun), "--standalone", "--nproc-per-node", "2", "-m",
                          "dcdc.cli", "train", str(TINY), "--out", str(run), "--no-progress",
                          *sets], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    assert res.stdout.count("model: ") == 1  # rank 0 alone reports and writes
    ddp = rows(run)
    assert [int(r["step"]) for r in ddp] == [1, 2, 3, 4]
    model, ck = load_checkpoint(run / "model.pt", expect="dcdc", dim=2)
    assert ck["extra"]["step"] == 4

    one = tmp_path / "one"
    train(tiny(*SETTINGS), one, echo=lambda *_: None)
    for a, b in zip(rows(one), ddp):
        for key in ("loss", "loss_1", "loss_2", "particles"):
            assert float(a[key]) == pytest.approx(float(b[key]), rel=1e-4), (key, a["step"])
    assert float(rows(one)[1]["val_loss"]) == pytest.approx(float(ddp[1]["val_loss"]), rel=1e-4)
