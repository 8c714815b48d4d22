"""Dataset layout, reader, generate (resume, shards, kill -9), merge, info, export."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from dcdc.data import Dataset, merge
from dcdc.data.generate import generate, random_jobs, run_job, scene_jobs
from dcdc.data.lagrangebench import export_lagrangebench
from dcdc.errors import DcdcError
from dcdc.scene import builtin_names
from dcdc.scene.random import RandomSceneConfig

ROOT = Path(__file__).resolve().parents[1]
CFG2 = RandomSceneConfig(dim=2, max_ratio=4.0)


def cli(*args, env=None, **kw):
    e = dict(os.environ, **(env or {}))
    return subprocess.run([sys.executable, "-m", "dcdc.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, env=e, **kw)


@pytest.fixture(scope="module")
def ballistic(tmp_path_factory):
    out = tmp_path_factory.mktemp("ds") / "a"
    jobs = random_jobs(3, 0, CFG2, duration=0.2, split="train")
    s = generate(jobs, out, simulator="ballistic", progress=False)
    assert s["done"] == 3
    return out


def test_layout_and_metadata(ballistic):
    ds = Dataset(ballistic)
    assert len(ds) == 3 and ds.incomplete == []
    t = ds["random_0_2d"]
    assert t.position.shape == (11, t.n_particles, 2) and t.position.dtype == np.float32
    assert t.velocity.shape == t.position.shape and np.allclose(t.time, 0.02 * np.arange(11))
    a = t.attrs
    for k in ("dim", "radius", "frame_dt", "gravity", "solver", "solver_settings", "seed", "dcdc_version",
              "git_commit", "scene_toml", "units", "complete", "split", "wall_time_s"):
        assert k in a, k
    assert a["frame_dt"] == 0.02 and a["radius"] == 0.025 and a["split"] == "train"
    assert json.loads(a["units"])["length"] == "m"
    assert "[phases." in a["scene_toml"]
    assert np.allclose(t.density, np.array([p.density for p in t.phases])[t.phase])
    # ballistic stand-in: x(t) = x0 + v0 t + g t^2 / 2
    tt = 0.2
    exp = t.position[0] + tt * t.velocity[0] + 0.5 * tt ** 2 * np.array([0, -9.81])
    assert np.allclose(t.position[-1], exp, atol=1e-4)
    w = t.window(3, 4)
    assert w["position"].shape == (4, t.n_particles, 2) and np.array_equal(w["position"][0], t.position[3])
    assert len(ds.windows(3)) == 3 * 9
    s = t.system(5)
    assert s.n_fluid == t.n_particles and np.allclose(s.x, t.position[5])
    assert json.load(open(ballistic / "dataset.json"))["trajectories"] == ds.names


def test_resume_skips_and_redoes_unfinished(ballistic, tmp_path):
    out = tmp_path / "r"
    jobs = random_jobs(3, 0, CFG2, duration=0.2)
    generate(jobs[:1], out, simulator="ballistic", progress=False)
    first = (out / "random_0_2d.h5").stat().st_mtime_ns
    # a half-written final-named file (no `complete`) and a stale temporary file
    with h5py.File(out / "random_1_2d.h5", "w") as f:
        f.create_group("random_1_2d").create_dataset("position", data=np.zeros((2, 3, 2)))
    (out / ".random_2_2d.h5.tmp-99999").write_bytes(b"\x89HDF garbage")
    ds = Dataset(out)
    assert ds.names == ["random_0_2d"] and len(ds.incomplete) == 2
    s = generate(jobs, out, simulator="ballistic", progress=False)
    assert s["skipped"] == 1 and s["done"] == 2
    assert (out / "random_0_2d.h5").stat().st_mtime_ns == first
    assert not list(out.glob(".*tmp*"))
    ref = Dataset(ballistic)
    for name in ref.names:
        assert np.array_equal(Dataset(out)[name].position, ref[name].position)


def test_resume_with_other_settings_is_refused(tmp_path):
    generate(random_jobs(1, 0, CFG2, duration=0.06), tmp_path, simulator="ballistic", progress=False)
    other = random_jobs(1, 0, RandomSceneConfig(dim=2, max_ratio=2.0), duration=0.06)
    with pytest.raises(DcdcError, match="other settings"):
        generate(other, tmp_path, simulator="ballistic", progress=False)


def test_shards_partition_the_jobs(tmp_path):
    jobs = random_jobs(5, 10, CFG2, duration=0.06)
    for i in range(3):
        generate(jobs, tmp_path / f"s{i}", shard=f"{i}/3", simulator="ballistic", progress=False)
    counts = [len(Dataset(tmp_path / f"s{i}")) for i in range(3)]
    assert counts == [2, 2, 1]
    n = merge([tmp_path / f"s{i}" for i in range(3)], tmp_path / "all.h5")
    ds = Dataset(tmp_path / "all.h5")
    assert n == 5 and sorted(ds.names) == sorted(j.name for j in jobs)
    merge([tmp_path / "all.h5"], tmp_path / "alldir")
    assert len(Dataset(tmp_path / "alldir")) == 5
    with pytest.raises(DcdcError, match="more than one input"):
        merge([tmp_path / "s0", tmp_path / "all.h5"], tmp_path / "dup.h5")
    with pytest.raises(DcdcError, match="--shard"):
        generate(jobs, tmp_path / "x", shard="3/3", simulator="ballistic", progress=False)


@pytest.mark.slow
def test_kill_mid_run_then_resume(tmp_path):
    """SIGKILL a real `dcdc generate` process mid-run: nothing half-written reads as done,
    and re-running the same command finishes the rest without redoing finished work."""
    out = tmp_path / "k"
    args = ["generate", "--random", "3", "--seed", "0", "--dim", "2", "--max-ratio", "4",
            "--duration", "0.4", "--simulator", "ballistic", "--no-progress", "-o", str(out)]
    p = subprocess.Popen([sys.executable, "-m", "dcdc.cli", *args], cwd=ROOT,
                         env=dict(os.environ, DCDC_BALLISTIC_DELAY="0.05"),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    t0 = time.time()
    while not (out / "random_0_2d.h5").exists():
        assert time.time() - t0 < 60 and p.poll() is None, "generate never wrote a trajectory"
        time.sleep(0.02)
    time.sleep(0.4)  # well into the second trajectory (20 frames x 0.05 s)
    p.send_signal(signal.SIGKILL)
    p.wait()
    ds = Dataset(out)
    assert 1 <= len(ds) < 3
    for t in ds:
        assert t.n_frames == 21 and np.isfinite(t.position).all()
    done_before = {n: (out / f"{n}.h5").stat().st_mtime_ns for n in ds.names}
    r = cli(*args)
    assert r.returncode == 0, r.stderr
    assert f"{len(done_before)} already done" in r.stdout
    ds = Dataset(out)
    assert len(ds) == 3 and ds.incomplete == []
    for n, m in done_before.items():
        assert (out / f"{n}.h5").stat().st_mtime_ns == m
    fresh = tmp_path / "fresh"
    assert cli(*args[:-1], str(fresh)).returncode == 0
    for n in ds.names:
        assert np.array_equal(ds[n].position, Dataset(fresh)[n].position)


def test_corrupt_file_is_one_line_error(ballistic, tmp_path):
    bad = tmp_path / "bad.h5"
    data = (ballistic / "random_0_2d.h5").read_bytes()
    bad.write_bytes(data[: len(data) // 3])
    with pytest.raises(DcdcError, match="truncated or corrupt"):
        Dataset(bad)
    r = cli("dataset", "info", str(bad))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "truncated or corrupt" in r.stderr
    r = cli("dataset", "info", str(tmp_path / "missing"))
    assert r.returncode == 2 and r.stderr.startswith("error:")


@pytest.mark.slow
def test_cli_info_and_lagrangebench_export(ballistic, tmp_path):
    r = cli("dataset", "info", str(ballistic), "--list")
    assert r.returncode == 0 and "3 finished" in r.stdout and "random_2_2d" in r.stdout
    meta = export_lagrangebench({"train": ballistic, "test": ballistic}, tmp_path / "lb")
    # 11 frames: LagrangeBench's sequence length counts the steps, 10
    assert meta["num_trajs_train"] == 3 and meta["sequence_length_train"] == 10
    with h5py.File(tmp_path / "lb" / "train.h5") as f:
        assert list(f.keys()) == ["00000", "00001", "00002"]
        pos, pt = f["00000/position"][()], f["00000/particle_type"][()]
    t = Dataset(ballistic)[0]
    n = t.n_particles + len(t.wall_x)   # then padding (type -1) up to num_particles_max
    assert pos.shape == (11, meta["num_particles_max"], 2) and set(np.unique(pt[:n])) <= {0, 1, 4}
    assert (pt[n:] == -1).all() and (pt[t.n_particles:n] == 1).all()
    for k in ("dt", "dx", "bounds", "vel_mean", "acc_std", "default_connectivity_radius", "dim"):
        assert k in json.load(open(tmp_path / "lb" / "metadata.json"))


def test_sample_dataset_in_git_reads():
    """data/sample: a small real-SPH dataset kept in git for tests and examples."""
    for sub in ("train2d", "test2d"):
        ds = Dataset(ROOT / "data" / "sample" / sub)
        assert len(ds) >= 1 and ds.incomplete == []
        for t in ds:
            assert t.attrs["solver"].startswith("dcdc.sph")
            assert json.loads(t.attrs["solver_settings"])["solver"] == "dfsph"
            assert np.isfinite(t.position).all() and t.n_frames > 10
            # the fluid moved, but stayed in its domain
            lo, hi = t.attrs["domain_min"], t.attrs["domain_max"]
            assert ((t.position[-1] >= lo - 1e-3) & (t.position[-1] <= hi + 1e-3)).all()
    test = Dataset(ROOT / "data" / "sample" / "test2d")
    ratios = [t.density.max() / t.density.min() for t in test if "random" in t.name]
    assert ratios and min(ratios) >= 10 - 1e-3  # held out: beyond the training range


@pytest.mark.slow
def test_sph_end_to_end_tiny_scene(tmp_path):
    """The real solver through `dcdc generate` on a tiny 2-D two-phase scene."""
    scene = tmp_path / "tiny.toml"
    scene.write_text((ROOT / "tests" / "test_scene_format.py").read_text().split('MINIMAL = """\\\n')[1]
                     .split('"""')[0])
    r = cli("generate", str(scene), "--duration", "0.1", "--no-progress", "-o", str(tmp_path / "d"))
    assert r.returncode == 0, r.stderr
    t = Dataset(tmp_path / "d")["t_2d"]
    assert t.n_frames == 6 and t.attrs["solver"].startswith("dcdc.sph")
    assert json.loads(t.attrs["solver_settings"])["solver"] == "dfsph"
    v = np.diff(t.position[:, :, 1], axis=0)
    assert (t.position[-1, :, 1] < t.position[0, :, 1] + 0.2).all() and np.isfinite(v).all()


@pytest.mark.slow
@pytest.mark.parametrize("name", builtin_names())
def test_builtin_runs_in_sph_2d(name, tmp_path):
    """Every built-in scene runs in the SPH solver (2-D, reduced resolution, a few frames)."""
    job = scene_jobs([name], dim=2, resolution=0.6, duration=0.1)[0]
    rec = run_job(job, tmp_path)
    assert rec["status"] == "ok", rec
    t = Dataset(tmp_path)[0]
    assert t.n_frames == 6 and np.isfinite(t.position).all()


@pytest.mark.slow
def test_parallel_workers_match_serial(ballistic, tmp_path):
    jobs = random_jobs(3, 0, CFG2, duration=0.2, split="train")
    s = generate(jobs, tmp_path / "p", workers=2, simulator="ballistic", progress=False)
    assert s["done"] == 3 and s["workers"] == 2
    ref = Dataset(ballistic)
    for t in Dataset(tmp_path / "p"):
        assert np.array_equal(t.position, ref[t.name].position)


@pytest.mark.slow
def test_scene_file_with_relative_mesh_and_emitter(tmp_path):
    r = cli("generate", "examples/my_scene.toml", "--dim", "2", "--duration", "0.1", "--simulator",
            "ballistic", "--no-progress", "-o", str(tmp_path))
    assert r.returncode == 0, r.stderr
    t = Dataset(tmp_path)["pour_over_pillar_2d"]
    assert (t.birth > 0).any() and "pillar.obj" in t.attrs["scene_toml"]
