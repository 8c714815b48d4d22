"""Finite but absurd values in a dataset (1e19 m/s): every command that reads them stops
with one line naming the file, trajectory and frame, before any neighbour grid or network
sees them (they used to end in numpy tracebacks)."""
import shutil

import h5py
import numpy as np
import pytest

from dcdc.data.dataset import Dataset
from dcdc.errors import DcdcError
from dcdc.model.checkpoint import save_checkpoint
from dcdc.model.networks import build_network
from helpers import dcdc_output

SAMPLE = "data/sample/train2d/random_0_2d.h5"


@pytest.fixture(scope="module")
def bad(tmp_path_factory):
    d = tmp_path_factory.mktemp("huge")
    ds = d / "ds"
    ds.mkdir()
    shutil.copy(SAMPLE, ds / "random_0_2d.h5")
    with h5py.File(ds / "random_0_2d.h5", "r+") as f:
        g = f[next(iter(f))]
        v = g["velocity"][...]
        v[3, 5, 0] = 1e19
        attrs = dict(g["velocity"].attrs)
        del g["velocity"]
        g.create_dataset("velocity", data=v)  # no checksum: an older-format array
        for k, val in attrs.items():
            g["velocity"].attrs[k] = val
    save_checkpoint(d / "m.pt", build_network("dcdc", 2))
    return d


def test_the_trajectory_names_the_frame(bad):
    t = Dataset(bad / "ds")[0]
    with pytest.raises(DcdcError, match=r"random_0_2d.*velocities beyond 1000 m/s.* frame 3"):
        t.window(2, 3)
    t.window(4, 3)  # frames after it are fine
    with pytest.raises(DcdcError, match="frame 3"):
        t.system(3)
    with pytest.raises(DcdcError, match="frame 3"):
        t.check_values()


@pytest.mark.parametrize("cmd", ["simulate", "evaluate"])
def test_commands_stop_with_one_line(bad, cmd, capsys, tmp_path):
    args = {"simulate": ["simulate", "--model", bad / "m.pt", "--dataset", bad / "ds",
                         "--trajectory", "random_0_2d", "--start-frame", "3", "--steps", "2",
                         "--out", tmp_path / "r.h5"],
            "evaluate": ["evaluate", "--model", bad / "m.pt", "--data", bad / "ds"]}[cmd]
    code, _, err = dcdc_output([str(a) for a in args], capsys)
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert "random_0_2d" in lines[0] and "frame 3" in lines[0]
    assert not (tmp_path / "r.h5").exists()
