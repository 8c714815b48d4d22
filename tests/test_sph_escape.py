"""Fluid leaving the domain: `[solver] on_escape = "error"` stops the run with one line,
"remove" deactivates the particle (a `death` time), and the dataset keeps the trajectory."""
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from dcdc.data import Dataset
from dcdc.data.dataset import removed_count
from dcdc.errors import DcdcError, SimulationDiverged
from dcdc.particles import ParticleSystem
from dcdc.scene import parse
from dcdc.sph import SPHConfig, Simulator
from helpers import format1_copy

ROOT = Path(__file__).resolve().parents[1]
FRAME_DT = 0.02
FRAMES = 30

# two layers (32 particles) sliding at 1 m/s off the open end of a ledge (x = 0.3) and
# falling through the bottom of the domain (y = -0.3 after the wall-thickness margin)
LEDGE = """\
name = "ledge"
dim = 2
duration = 0.6

[domain]
min = [-0.6, -0.2]
max = [0.6, 0.5]

[phases.water]
density = 1000

[phases.heavy]
density = 2000

[walls.ledge]
shape = "box"
min = [-0.4, -0.1]
max = [0.3, 0.0]

[[fluid]]
phase = "water"
shape = "box"
min = [-0.1, 0.0]
max = [0.3, 0.1]
velocity = [1.0, 0.0]

[[fluid]]
phase = "heavy"
shape = "box"
min = [-0.1, 0.1]
max = [0.3, 0.2]
velocity = [1.0, 0.0]

[solver]
on_escape = "ESCAPE"
"""


def scene(on_escape: str):
    return parse(LEDGE.replace("ESCAPE", on_escape), "ledge.toml")


def simulator(on_escape: str) -> Simulator:
    sc = scene(on_escape)
    return Simulator(sc.realize(), SPHConfig.from_dict(sc.solver))


@pytest.fixture(scope="module")
def removed_run():
    """The "remove" run: positions of every frame, the simulator at the end."""
    sim = simulator("remove")
    xs = [sim.system.x.copy()]
    for _ in range(FRAMES):
        sim.advance(FRAME_DT)
        xs.append(sim.system.x.copy())
    return sim, np.array(xs)


def test_bad_on_escape_is_one_line():
    with pytest.raises(DcdcError, match="on_escape") as e:
        SPHConfig(on_escape="vanish")
    assert "\n" not in str(e.value)
    with pytest.raises(DcdcError, match=r"ledge.toml: \[solver\]: sph.on_escape must be one of "
                                        r"error, remove") as e:
        scene("vanish").check_solver()
    assert "\n" not in str(e.value)
    sy = scene("remove").realize()
    sy.death[0] = np.nan
    with pytest.raises(DcdcError, match="death"):
        Simulator(sy)


def test_error_stops_the_run_with_one_line():
    sim = simulator("error")
    with pytest.raises(SimulationDiverged, match=r"fluid particle\(s\) left the domain at t = ") as e:
        for _ in range(FRAMES):
            sim.advance(FRAME_DT)
    assert "\n" not in str(e.value) and 0.2 < sim.time < 0.4


def test_remove_counts_and_freezes(removed_run):
    sim, xs = removed_run
    sy = sim.system
    death = sy.death
    gone = np.isfinite(death)
    n0 = sy.n_fluid
    assert sim.time == pytest.approx(FRAMES * FRAME_DT)
    assert 0 < gone.sum() < n0
    assert sim.totals["removed"] == gone.sum() == sy.n_removed
    lo, hi = sy.domain
    for k in range(FRAMES + 1):
        t = k * FRAME_DT
        act = sy.active(t)
        assert act.sum() == n0 - (death <= t + 1e-9).sum()
        # the active particles are inside the domain, the rest are where they left it
        assert ((xs[k][act] >= lo) & (xs[k][act] <= hi)).all()
        assert not ((xs[k][~act] >= lo) & (xs[k][~act] <= hi)).all(1).any()
        # mass of the fluid still simulated = initial - removed
        m = sy.rest_density * sim.V0
        assert m[act].sum() == pytest.approx(m.sum() - m[death <= t + 1e-9].sum())
    # frozen: a removed particle does not move after the frame in which it left
    for i in np.flatnonzero(gone):
        k = int(np.ceil(death[i] / FRAME_DT - 1e-9))
        assert np.array_equal(xs[k:, i], np.repeat(xs[-1:, i], FRAMES + 1 - k, axis=0))
    assert np.isnan(sim.density()[gone]).all() and (sim.pressure()[gone] == 0).all()


def test_remove_changes_nothing_before_the_first_escape(removed_run):
    sim, xs = removed_run
    k_first = int(np.floor(sim.system.death.min() / FRAME_DT - 1e-9))  # last frame before it
    ref = simulator("error")
    for k in range(1, k_first + 1):
        ref.advance(FRAME_DT)
        assert np.array_equal(ref.system.x, xs[k])


def test_removed_particles_are_nobodys_neighbours():
    """After a removal the remaining particles' densities are those of a system in which
    the removed ones do not exist, although some lie within the kernel support h."""
    sim = simulator("remove")
    for _ in range(FRAMES):
        sim.advance(FRAME_DT)
        act = sim.system.active(sim.time)
        dead = np.isfinite(sim.system.death)
        if not (dead.any() and act.any()):
            continue
        d = np.linalg.norm(sim.system.x[act][:, None] - sim.system.x[dead][None], axis=2)
        if d.min() < 0.9 * sim.h:
            break
    else:
        pytest.fail("no removed particle ever came within h of a remaining one")
    sy = sim.system
    alone = ParticleSystem(2, sy.radius, sy.x[act], sy.v[act], sy.phase[act], sy.phases,
                           sy.wall_x, sy.wall_n, sy.gravity, sy.domain, wall_sdf=sy.wall_sdf)
    fresh = Simulator(alone, sim.cfg)
    assert np.allclose(sim.density()[act], fresh.density(), rtol=1e-12, atol=0)


def cli(*args):
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "dcdc.cli", *args], capture_output=True,
                          text=True, cwd=ROOT, env=env)


@pytest.mark.slow
def test_generate_keeps_the_trajectory_and_its_deaths(removed_run, tmp_path):
    sim, xs = removed_run
    f = tmp_path / "ledge.toml"
    f.write_text(LEDGE.replace("ESCAPE", "remove"))
    r = cli("generate", str(f), "--no-progress", "-o", str(tmp_path / "ok"))
    assert r.returncode == 0, r.stderr
    n = int(np.isfinite(sim.system.death).sum())
    assert f"0 failed, {n} particle(s) removed after leaving the domain" in r.stdout
    t = Dataset(tmp_path / "ok")["ledge_2d"]
    assert t.death.dtype == np.float64 and np.array_equal(t.death, sim.system.death)
    assert t.removed == n == t.attrs["removed"] == removed_count(t.ref.file, t.name)
    assert json.loads(t.attrs["solver_settings"])["on_escape"] == "remove"
    assert np.allclose(t.position, xs, atol=1e-6)
    assert [int(t.active(k).sum()) for k in (0, FRAMES)] == [t.n_particles, t.n_particles - n]
    assert np.array_equal(t.window(2, 3)["death"], t.death)
    assert np.array_equal(t.system(FRAMES).active(t.time[-1]), t.active(FRAMES))
    # training windows leave out particles removed before the window's last frame
    from dcdc.train.sampler import load_window
    ds = Dataset(tmp_path / "ok")
    assert load_window(ds, 0, 0, FRAMES + 1)["position"].shape[1] == t.n_particles - n
    assert load_window(ds, 0, 0, 2)["position"].shape[1] == int((t.death > t.time[1]).sum())
    index = json.loads((tmp_path / "ok" / "dataset.json").read_text())
    assert index["runs"][-1]["removed"] == n and Dataset(tmp_path / "ok").summary()["removed"] == n

    f.write_text(LEDGE.replace("ESCAPE", "error"))
    r = cli("generate", str(f), "--no-progress", "-o", str(tmp_path / "err"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "failed ledge_2d: 1 fluid particle(s) left the domain at t = " in r.stderr
    assert (tmp_path / "err" / "ledge_2d.failed.json").exists()


def test_old_files_read_as_all_alive(tmp_path):
    format1_copy(ROOT / "data" / "sample" / "train2d" / "random_0_2d.h5", tmp_path / "old.h5")
    t = Dataset(tmp_path / "old.h5")[0]
    with h5py.File(t.ref.file) as h:
        assert "death" not in h[t.name]  # written before removal existed
    assert np.isinf(t.death).all() and t.death.shape == (t.n_particles,) and t.removed == 0
    assert np.array_equal(t.active(0), t.birth <= 1e-9)
    assert removed_count(t.ref.file, t.name) == 0
    assert np.isinf(t.system(3).death).all()
