"""dcdc train: config, curriculum, sampler, loss and a tiny in-process run (sample data)."""
import csv
from pathlib import Path

import numpy as np
import pytest
import torch

from dcdc.cli import main
from dcdc.data.dataset import Dataset
from dcdc.errors import DcdcError
from dcdc.model.checkpoint import load_checkpoint, read_checkpoint
from dcdc.model.integrator import step
from dcdc.model.networks import build_network
from dcdc.train.config import TrainConfig, load_config
from dcdc.train.curriculum import CurriculumConfig, Stage, allowed, max_density_ratio
from dcdc.train.loss import neighbour_weights, position_error, scene_mean, unrolled_loss
from dcdc.train.sampler import WindowSampler, augment, collate, load_window, push_into_walls
from dcdc.train.trainer import Trainer, checkpoints, train

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "examples" / "train_2d_tiny.toml"
TRAIN = ROOT / "data" / "sample" / "train2d"
VAL = ROOT / "data" / "sample" / "test2d"
PATHS = [f"data.train='{TRAIN}'", f"data.val='{VAL}'"]


def tiny(*overrides, tensorboard=False):
    return load_config(TINY, PATHS + [f"log.tensorboard={str(tensorboard).lower()}",
                                      "log.progress=false", *overrides])


def rows(run):
    with open(Path(run) / "metrics.csv", newline="") as f:
        return list(csv.DictReader(f))


# ---------------------------------------------------------------------- config
def test_config_round_trip_and_overrides():
    cfg = tiny("optim.lr=2e-4", "model.channels=[4, 6, 6]", "loss.step_weights=[0.25, 0.75]")
    assert cfg.optim.lr == 2e-4 and cfg.model.channels == (4, 6, 6)
    assert cfg.loss.weights() == [0.25, 0.75]
    assert cfg.curriculum.stages[1] == Stage(0.6, 1.5)
    again = TrainConfig.from_dict(cfg.to_dict())
    assert again == cfg
    assert TrainConfig().loss.weights() == [0.5, 0.5]  # DeepLagrangianFluids' ½, ½


@pytest.mark.parametrize("override, msg", [
    ("optim.lrr=1", "unknown setting optim.lrr"),
    ("optim.lr=-1", "optim.lr must be > 0"),
    ("optim.lr=nan", "optim.lr must be a finite number"),
    ("model.kernel_size='four'", "model.kernel_size must be an integer"),
    ("model.channels=[8, -1, 8]", "model.channels must be a non-empty list of positive"),
    ("model.rho_ref=-5", "model.rho_ref must be > 0"),
    ("model.name='gns'", "model.name must be one of dcdc, cconv, dcdc-antisym"),
    ("data.batch_scenes=0", "data.batch_scenes must be >= 1"),
    ("loss.step_weights=[1.0]", "loss.step_weights must be empty or 2 numbers"),
    ("curriculum.stages=[{until=0.5, max_ratio=3.0}, {until=0.4, max_ratio=4.0}]",
     r"curriculum.stages\[1\].until must be in \(0.5, 1\]"),
    ("curriculum.stages=[{until=0.5, max_ratio=3.0}, {until=0.8, max_ratio=2.0}]",
     r"max_ratio must be >= 3"),
    ("optim=3", "optim must be a table"),
    ("nonsense", "--set wants key=value"),
])
def test_config_mistakes_are_one_line(override, msg):
    with pytest.raises(DcdcError, match=msg) as e:
        tiny(override)
    assert "\n" not in str(e.value)


def test_cli_bad_config_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[optim]\nsteps = 'many'\n")
    for argv in (["train", str(bad)], ["train", str(tmp_path / "missing.toml")],
                 ["train", str(TINY), "--set", "loss.gamma=7"]):
        with pytest.raises(SystemExit) as e:
            main(argv + ["--out", str(tmp_path / "run")])
        assert e.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1, err


# ---------------------------------------------------------------------- curriculum
def test_curriculum_stages_are_data():
    c = CurriculumConfig([Stage(0.2, 1.0), Stage(0.5, 3.0)])
    assert [c.stage_at(s, 100) for s in (0, 19, 20, 49, 50, 99)] == [
        (0, 1.0), (0, 1.0), (1, 3.0), (1, 3.0), (2, None), (2, None)]
    assert allowed([1.0, 1.0000001, 2.0, 3.5], 1.0).tolist() == [True, True, False, False]
    assert allowed([1.0, 2.0, 3.5], 3.0).tolist() == [True, True, False]
    assert allowed([1.0, 9.0], None).all()
    assert CurriculumConfig([]).stage_at(0, 10) == (0, None)


def test_max_density_ratio_from_attribute_or_present_particles():
    class Fake:
        def __init__(self, attrs, density, birth, time):
            self.attrs, self.density, self.birth, self.time = attrs, density, birth, time
            self.n_frames = len(time)

    t = np.linspace(0, 1, 51)
    assert max_density_ratio(Fake({"max_density_ratio": 4.5}, np.ones(3), np.zeros(3), t)) == 4.5
    # the 5000 kg/m³ particle is born after the end: it never takes part
    f = Fake({}, np.array([1000.0, 2000.0, 5000.0]), np.array([0.0, 0.5, 2.0]), t)
    assert max_density_ratio(f) == pytest.approx(2.0)
    ds = Dataset(TRAIN)
    got = sorted(round(max_density_ratio(x), 3) for x in ds)
    assert got == [1.0, 1.23, 2.533]  # one of them has a single phase


# ---------------------------------------------------------------------- sampler
def test_sampler_follows_the_curriculum_and_is_a_function_of_seed_and_step():
    ds = Dataset(TRAIN)
    s = WindowSampler(ds, 3, seed=7)
    assert len(s.windows) == 3 * 49
    low = s.batch(5, 4, 1.1)
    assert all(max_density_ratio(ds[t]) < 1.1 for t, _ in low)
    assert low == WindowSampler(ds, 3, seed=7).batch(5, 4, 1.1)  # reproducible
    assert low != s.batch(6, 4, 1.1)
    assert {t for st in range(20) for t, _ in s.batch(st, 4, None)} == {0, 1, 2}
    with pytest.raises(DcdcError, match="curriculum stage 0 .max_ratio 0.9. selects no trajectory"):
        s.check_stages([0.9])


def test_sampler_oversamples_the_start_of_the_trajectories():
    ds = Dataset(TRAIN)
    plain = WindowSampler(ds, 3, seed=7)
    # early_fraction 0 draws exactly what the plain sampler draws
    assert WindowSampler(ds, 3, seed=7, early_fraction=0.0).batch(3, 8, None) == plain.batch(3, 8, None)
    starts = [st for k in range(50) for _, st in plain.batch(k, 8, None)]
    assert np.mean(np.array(starts) < 5) < 0.3  # uniform: 5 of 49 starts per trajectory
    allearly = WindowSampler(ds, 3, seed=7, early_fraction=1.0, early_frames=5)
    got = [w for k in range(50) for w in allearly.batch(k, 8, 1.1)]
    assert all(st < 5 for _, st in got) and all(max_density_ratio(ds[t]) < 1.1 for t, _ in got)
    half = WindowSampler(ds, 3, seed=7, early_fraction=0.5, early_frames=5)
    frac = np.mean([st < 5 for k in range(100) for _, st in half.batch(k, 8, None)])
    assert 0.45 < frac < 0.65  # 0.5 swapped in, plus the uniform draws' own ≈ 10 %
    assert half.batch(9, 8, None) == WindowSampler(ds, 3, seed=7, early_fraction=0.5,
                                                   early_frames=5).batch(9, 8, None)


def test_augmentation_keeps_gravity_and_distances():
    rng = np.random.default_rng(0)
    n, m = 30, 10
    g = np.array([0.0, -9.81, 0.0])
    sample = {"position": rng.normal(size=(3, n, 3)), "velocity": rng.normal(size=(n, 3)),
              "density": np.full(n, 1000.0), "wall_position": rng.normal(size=(m, 3)),
              "wall_normal": rng.normal(size=(m, 3)), "gravity": g}
    out = augment(sample, np.random.default_rng(3), rotate=True, noise_std=0.0)
    for k in ("position", "velocity", "wall_position", "wall_normal"):
        assert not np.allclose(out[k], sample[k])
        np.testing.assert_allclose(out[k][..., 1], sample[k][..., 1], atol=1e-12)  # along g
        np.testing.assert_allclose(np.linalg.norm(out[k], axis=-1),
                                   np.linalg.norm(sample[k], axis=-1), rtol=1e-12)
    # the same isometry for every array: relative geometry is kept
    d0 = sample["position"][0][:, None] - sample["wall_position"][None]
    d1 = out["position"][0][:, None] - out["wall_position"][None]
    np.testing.assert_allclose(np.linalg.norm(d0, axis=-1), np.linalg.norm(d1, axis=-1))
    # 2-D: a mirror across the gravity line, or nothing
    s2 = {k: (v[..., :2] if k != "density" else v) for k, v in sample.items()}
    outs = [augment(s2, np.random.default_rng(i), True, 0.0)["position"] for i in range(8)]
    flipped = [np.allclose(o[..., 0], -s2["position"][..., 0]) for o in outs]
    same = [np.allclose(o, s2["position"]) for o in outs]
    assert all(f or s for f, s in zip(flipped, same)) and any(flipped) and any(same)
    noisy = augment(sample, np.random.default_rng(1), rotate=False, noise_std=0.01)
    dev = noisy["position"][0] - sample["position"][0]
    assert 0.005 < dev.std() < 0.02 and np.array_equal(noisy["position"][1:], sample["position"][1:])


def test_collate_concatenates_scenes_with_offsets():
    ds = Dataset(TRAIN)
    samples = [load_window(ds, i, 4, 3) for i in range(3)]
    b = collate(samples)
    n = [len(s["density"]) for s in samples]
    w = [len(s["wall_position"]) for s in samples]
    assert b.position.shape == (3, sum(n), 2) and b.wall_position.shape == (sum(w), 2)
    assert b.scenes.fluid.tolist() == [0, n[0], n[0] + n[1], sum(n)]
    assert b.scenes.wall.tolist() == [0, w[0], w[0] + w[1], sum(w)]
    assert b.scene_index().tolist() == [0] * n[0] + [1] * n[1] + [2] * n[2]
    torch.testing.assert_close(b.position[1, n[0]:n[0] + n[1]],
                               torch.tensor(samples[1]["position"][1], dtype=torch.float32))


# ---------------------------------------------------------------------- loss
def test_loss_terms():
    pred = torch.tensor([[0.0, 0.0], [3.0, 4.0]])
    tgt = torch.zeros(2, 2)
    torch.testing.assert_close(position_error(pred, tgt, 0.5),
                               torch.tensor([1e-9 ** 0.25, (25 + 1e-9) ** 0.25]))
    torch.testing.assert_close(neighbour_weights([0, 40], 40.0, pred),
                               torch.tensor([1.0, np.exp(-1.0)], dtype=torch.float32))
    torch.testing.assert_close(neighbour_weights([0, 40], 0.0, pred), torch.ones(2))


def test_unrolled_loss_is_the_documented_formula():
    """L = Σ_k w_k mean_scenes mean_i exp(-n_i/n0) (|x̂ - x|² + ε)^(γ/2), written out here
    with one step() per scene and per unrolled step."""
    ds = Dataset(TRAIN)
    samples = [load_window(ds, i, 10, 3) for i in (0, 2)]
    b = collate(samples, torch.float64)
    torch.manual_seed(0)
    net = build_network("dcdc", 2, channels=[8, 8, 8]).double()
    cfg = tiny("loss.step_weights=[0.3, 0.7]", "loss.gamma=0.5", "loss.neighbor_scale=13.3").loss
    loss, parts = unrolled_loss(net, b, cfg)
    expect = []
    for k in range(2):
        per_scene = []
        for s in samples:
            x, v = torch.tensor(s["position"][0]), torch.tensor(s["velocity"])
            for _ in range(k + 1):
                x, v = step(net, x, v, s["density"], s["wall_position"], s["wall_normal"],
                            gravity=s["gravity"])
            n = np.diff(net.last_context.fluid.row_splits)
            e = torch.exp(-torch.tensor(n, dtype=torch.float64) / 13.3) * \
                ((x - torch.tensor(s["position"][k + 1])).square().sum(1) + 1e-9) ** 0.25
            per_scene.append(e.mean())
        expect.append(torch.stack(per_scene).mean())
    torch.testing.assert_close(torch.tensor(parts, dtype=torch.float64), torch.stack(expect))
    torch.testing.assert_close(loss, 0.3 * expect[0] + 0.7 * expect[1])
    loss.backward()
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in net.parameters())


def test_scene_mean_counts_each_scene_once():
    b = collate([{"position": np.zeros((1, n, 2)), "velocity": np.zeros((n, 2)),
                  "density": np.ones(n), "wall_position": np.zeros((0, 2)),
                  "wall_normal": np.zeros((0, 2)), "gravity": np.array([0, -9.81])}
                 for n in (1, 3)])
    assert float(scene_mean(torch.tensor([4.0, 1.0, 1.0, 1.0]), b)) == pytest.approx(2.5)


# ---------------------------------------------------------------------- a run
@pytest.mark.slow
def test_tiny_run_writes_logs_checkpoints_and_a_loadable_model(tmp_path):
    run = tmp_path / "run"
    path = train(tiny("optim.steps=6", "log.checkpoint_every=3", "eval.every=3",
                      tensorboard=True), run, echo=lambda *_: None)
    assert path == run / "model.pt"
    r = rows(run)
    assert [int(x["step"]) for x in r] == [1, 2, 3, 4, 5, 6]
    assert [x["stage"] for x in r] == ["0", "0", "1", "1", "2", "2"]  # 0.3 / 0.6 of 6 steps
    assert all(float(x["loss"]) > 0 for x in r) and r[2]["val_loss"] and not r[1]["val_loss"]
    assert [p.name for p in checkpoints(run)] == ["step_00000006.pt", "step_00000003.pt"]
    assert list((run / "tensorboard").glob("events.out.tfevents.*"))
    assert load_config(run / "config.toml") == tiny("optim.steps=6", "log.checkpoint_every=3",
                                                    "eval.every=3", tensorboard=True)
    model, ck = load_checkpoint(path, expect="dcdc", dim=2)
    assert ck["config"]["particle_radius"] == 0.025 and ck["config"]["frame_dt"] == 0.02
    assert ck["extra"]["step"] == 6 and "optimizer" not in ck["extra"]
    assert ck["extra"]["train_config"]["optim"]["steps"] == 6
    assert ck["data"]["trajectories"] == 3 and ck["data"]["density_ratio_max"] > 2.5
    assert "optimizer" in read_checkpoint(checkpoints(run)[0])["extra"]
    assert (run / "best.pt").exists()
    # the trained weights moved away from the initial ones
    torch.manual_seed(0)
    init = build_network("dcdc", 2, channels=[8, 16, 16])
    assert not torch.allclose(init.dense0.weight, model.dense0.weight)


@pytest.mark.slow
def test_run_directory_and_data_mismatches_are_refused(tmp_path):
    run = tmp_path / "run"
    train(tiny("optim.steps=2"), run, echo=lambda *_: None)
    with pytest.raises(DcdcError, match="already holds a training run; pass --resume"):
        Trainer(tiny("optim.steps=2"), run)
    with pytest.raises(DcdcError, match="--resume: .* another optim.lr"):
        Trainer(tiny("optim.steps=4", "optim.lr=0.5"), run, resume=True, echo=lambda *_: None)
    with pytest.raises(DcdcError, match="trained for particle radius 0.0125 m but training "
                                        "dataset .* has 0.025 m"):
        Trainer(tiny("model.particle_radius=0.0125"), tmp_path / "r2")
    assert not (tmp_path / "r2").exists()  # refused before anything was written
    with pytest.raises(DcdcError, match="steps dt = 0.01 s but training dataset"):
        Trainer(tiny("model.frame_dt=0.01"), tmp_path / "r3")
    (tmp_path / "file").write_text("x")
    with pytest.raises(DcdcError, match="is a file, not a directory"):
        Trainer(tiny(), tmp_path / "file")
    if not torch.cuda.is_available():
        with pytest.raises(DcdcError, match="--device cuda: no CUDA device is available"):
            Trainer(tiny(), tmp_path / "r4", device="cuda")


def _synthetic_3d(path, n_traj=2, n=60, frames=5):
    """A small 3-D dataset (free fall of a jittered block over a floor): not physics, just
    the 3-D code path — rotation about gravity, 3-D network, stored max_density_ratio."""
    from dcdc.data.dataset import write_trajectory
    from dcdc.particles import ParticleSystem, Phase

    path.mkdir()
    for k in range(n_traj):
        rng = np.random.default_rng(k)
        x0 = rng.uniform(0, 0.2, (n, 3)) + [0, 0.1, 0]
        v0 = rng.normal(scale=0.05, size=(n, 3))
        phase = (x0[:, 1] > 0.2).astype(int)
        walls = np.stack(np.meshgrid(np.arange(0, 0.25, 0.05), [0.0], np.arange(0, 0.25, 0.05),
                                     indexing="ij"), -1).reshape(-1, 3)
        ps = ParticleSystem(3, 0.025, x0, v0, phase, [Phase("a", 1000.0), Phase("b", 2500.0)],
                            walls, np.tile([0, 1.0, 0], (len(walls), 1)), (0, -9.81, 0),
                            (np.full(3, -1.0), np.full(3, 1.0)))
        t = np.arange(frames) * 0.02
        xs = np.stack([x0 + v0 * s - 0.5 * 9.81 * s ** 2 * np.array([0, 1, 0]) for s in t])
        vs = np.stack([v0 - 9.81 * s * np.array([0, 1, 0]) for s in t])
        write_trajectory(path / f"t{k}.h5", f"t{k}", xs, vs, t, ps,
                         {"frame_dt": 0.02, "max_density_ratio": 2.5 if k else 1.0})


def test_3d_training_path(tmp_path):
    data = tmp_path / "d3"
    _synthetic_3d(data)
    cfg = tiny(f"data.train='{data}'", "data.val=''", "optim.steps=3", "data.batch_scenes=2",
               "loss.neighbor_scale=40.0",
               "curriculum.stages=[{until=0.4, max_ratio=1.0}]")
    ds = Dataset(data)
    assert sorted(max_density_ratio(t) for t in ds) == [1.0, 2.5]  # the stored attribute
    path = train(cfg, tmp_path / "run3", echo=lambda *_: None)
    model, ck = load_checkpoint(path, expect="dcdc", dim=3)
    assert [r["stage"] for r in rows(tmp_path / "run3")] == ["0", "0", "1"]
    assert ck["data"]["density_ratio_max"] == 2.5


def test_a_non_finite_loss_stops_with_one_line(tmp_path, monkeypatch):
    import dcdc.train.trainer as trainer_mod

    monkeypatch.setattr(trainer_mod, "unrolled_loss",
                        lambda *a, **k: (torch.tensor(float("nan"), requires_grad=True), [0.0, 0.0]))
    with pytest.raises(DcdcError, match="training diverged at step 1: the loss is not finite"):
        train(tiny("optim.steps=2"), tmp_path / "nan", echo=lambda *_: None)


@pytest.mark.slow
def test_resume_skips_a_damaged_checkpoint(tmp_path):
    run = tmp_path / "run"
    cfg = tiny("optim.steps=4", "log.checkpoint_every=2", "eval.every=0")
    train(cfg, run, echo=lambda *_: None)
    newest = checkpoints(run)[0]
    assert newest.name == "step_00000004.pt"
    newest.write_bytes(newest.read_bytes()[:1000])  # truncated
    msgs = []
    train(cfg, run, resume=True, echo=msgs.append)
    assert any("skipping step_00000004.pt" in m for m in msgs)
    assert any("from step_00000002.pt (step 2)" in m for m in msgs)
    assert [int(r["step"]) for r in rows(run)] == [1, 2, 3, 4]
    assert load_checkpoint(checkpoints(run)[0])[1]["extra"]["step"] == 4  # rewritten


@pytest.mark.slow
def test_fine_tuning_starts_from_the_given_weights(tmp_path):
    first = train(tiny("optim.steps=2"), tmp_path / "a", echo=lambda *_: None)
    msgs = []
    # lr = 1e-12: one Adam step moves each weight by ~1e-12, so they stay those of model.init
    path = train(tiny("optim.steps=1", "optim.lr=1e-12", f"model.init='{first}'"), tmp_path / "b",
                 echo=msgs.append)
    a, _ = load_checkpoint(first)
    b, ck = load_checkpoint(path)
    assert all(torch.allclose(p, q, rtol=0, atol=1e-9) for p, q in zip(a.parameters(), b.parameters()))
    fresh, _ = load_checkpoint(train(tiny("optim.steps=1", "optim.lr=1e-12", "optim.seed=5"),
                                     tmp_path / "e", echo=lambda *_: None))
    assert not torch.allclose(fresh.dense0.weight, b.dense0.weight)  # the test can fail
    assert any("starting from the weights of" in m for m in msgs)
    assert ck["extra"]["train_config"]["model"]["init"] == str(first)
    # another network's weights are refused with one line, before any training
    with pytest.raises(DcdcError, match=r"model.init: .* holds another network \(channels"):
        train(tiny("optim.steps=1", f"model.init='{first}'", "model.channels=[4, 8, 8]"),
              tmp_path / "c", echo=lambda *_: None)
    with pytest.raises(DcdcError, match="does not exist"):
        train(tiny("optim.steps=1", "model.init='nope.pt'"), tmp_path / "d", echo=lambda *_: None)


def test_push_into_walls_moves_a_share_of_the_first_row_behind_its_wall():
    # a floor of wall particles at y = 0 (normal +y), fluid rows at y = r, 3r, 5r
    r = 0.025
    wx = np.stack([np.arange(-20, 21) * 2 * r, np.zeros(41)], axis=1)
    wn = np.tile([0.0, 1.0], (41, 1))
    gx, gy = np.meshgrid(np.arange(-10, 11) * 2 * r, [r, 3 * r, 5 * r])
    x = np.stack([gx.ravel(), gy.ravel()], axis=1)
    out = push_into_walls(x, wx, wn, np.random.default_rng(0), depth=r, fraction=0.5,
                          reach=2 * r)
    moved = np.any(out != x, axis=1)
    first = np.isclose(x[:, 1], r)
    assert not moved[~first].any()                      # only particles within reach
    assert 0.2 < moved[first].mean() < 0.8              # about the share asked for
    assert np.all(out[moved, 1] <= 0) and np.all(out[moved, 1] >= -r)  # behind, ≤ depth
    np.testing.assert_array_equal(out[moved, 0], x[moved, 0])  # along the normal only
    # through augment: targets untouched; off by default; reproducible from the rng
    sample = {"position": np.stack([x, x + 0.001]), "velocity": np.zeros_like(x),
              "density": np.full(len(x), 1000.0), "wall_position": wx, "wall_normal": wn,
              "gravity": np.array([0.0, -9.81])}
    a = augment(sample, np.random.default_rng(4), False, 0.0, r, 0.5, 2 * r)
    b = augment(sample, np.random.default_rng(4), False, 0.0, r, 0.5, 2 * r)
    np.testing.assert_array_equal(a["position"], b["position"])
    np.testing.assert_array_equal(a["position"][1], sample["position"][1])
    assert (a["position"][0][:, 1] < 0).any()
    c = augment(sample, np.random.default_rng(4), False, 0.0)
    np.testing.assert_array_equal(c["position"], sample["position"])
