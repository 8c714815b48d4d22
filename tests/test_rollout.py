"""dcdc.evaluate.rollout (NeuralSimulator, guard, emitters) and `dcdc simulate`."""
import json

import h5py
import numpy as np
import pytest
import torch

from dcdc.data.dataset import Dataset
from dcdc.errors import DcdcError
from dcdc.evaluate.rollout import Guard, NeuralSimulator, RolloutStopped, run
from dcdc.model.checkpoint import save_checkpoint
from dcdc.model.networks import build_network
from dcdc.particles import ParticleSystem, Phase
from helpers import dcdc_output as _cli

SAMPLE = "data/sample/train2d"
DT, G = 0.02, -9.81


def zero_net(dim=2, **cfg):
    """A network whose correction is exactly 0: a rollout is then ballistic (eq. 2)."""
    net = build_network("cconv", dim, **cfg)
    for p in net.parameters():
        p.data.zero_()
    return net


def box_system(x, v, birth=None, phase=None, walls=True):
    """2-D fluid particles over a floor of wall particles at y = 0 (3 layers, normals up)."""
    x = np.asarray(x, dtype=float)
    xs = np.arange(-20, 21) * 0.05
    wx = np.array([(a, -k * 0.05) for a in xs for k in range(3)]) if walls else np.zeros((0, 2))
    wn = np.tile([0.0, 1.0], (len(wx), 1))
    return ParticleSystem(2, 0.025, x, np.asarray(v, dtype=float),
                          np.zeros(len(x), int) if phase is None else phase,
                          [Phase("water", 1000.0), Phase("heavy", 3000.0)], wx, wn, (0, G),
                          ((-1.0, -0.5), (1.0, 2.0)), birth)


def ballistic(x, v, n):
    """n steps of Algorithm 1 with Δx = 0: x' = x + Δt v + ½ Δt² g, v' = (x' − x)/Δt."""
    x, v = np.array(x, float), np.array(v, float)
    g = np.array([0.0, G])
    for _ in range(n):
        x_new = x + DT * v + 0.5 * DT * DT * g
        x, v = x_new, (x_new - x) / DT
    return x, v


@pytest.mark.slow
def test_ballistic_steps_and_emitter():
    x0 = np.array([[0.0, 1.0], [0.3, 1.2], [0.5, 1.5]])
    v0 = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, -1.0]])
    sy = box_system(x0.copy(), v0.copy(), birth=[0.0, 0.0, 0.05])  # advanced in place
    sim = NeuralSimulator(zero_net(), sy)
    st = sim.advance(0.04)  # two steps; the third particle is not born yet
    assert st["steps"] == 2 and sim.time == pytest.approx(0.04) and st["active"] == 2
    x2, v2 = ballistic(x0[:2], v0[:2], 2)
    assert sim.system.x[:2] == pytest.approx(x2, abs=1e-5)
    assert sim.system.v[:2] == pytest.approx(v2, abs=1e-4)
    assert sim.system.x[2] == pytest.approx(x0[2]) and sim.system.v[2] == pytest.approx(v0[2])
    sim.advance(0.02)  # t = 0.04 < birth 0.05: still waiting
    assert sim.stats["active"] == 2 and sim.system.x[2] == pytest.approx(x0[2])
    sim.advance(0.04)  # born at the step that starts at t = 0.06: two steps since
    assert sim.stats["active"] == 3
    assert sim.system.x[2] == pytest.approx(ballistic(x0[2:], v0[2:], 2)[0][0], abs=1e-5)


def test_run_like_the_sph_simulator():
    x0, v0 = np.array([[0.0, 1.0]]), np.array([[0.5, 0.0]])
    sim = NeuralSimulator(zero_net(), box_system(x0.copy(), v0.copy()))
    seen = []
    sim.run(0.12, 0.04, callback=lambda s: seen.append(round(s.time, 6)))
    assert seen == [0.04, 0.08, 0.12] and sim.steps == 6
    assert sim.system.x == pytest.approx(ballistic(x0, v0, 6)[0], abs=1e-5)


def test_frame_dt_must_be_a_multiple_of_the_step():
    sim = NeuralSimulator(zero_net(), box_system([[0, 1.0]], [[0, 0]]))
    with pytest.raises(DcdcError, match="not a multiple"):
        sim.advance(0.03)
    with pytest.raises(DcdcError, match="> 0"):
        sim.advance(0.0)


@pytest.mark.parametrize("case", ["dim", "density_len", "density_neg", "radius"])
def test_inputs_rejected_with_one_line(case):
    sy = box_system([[0, 1.0], [0.1, 1.0]], [[0, 0], [0, 0]])
    kw, net = {}, zero_net()
    if case == "dim":
        net = zero_net(3)
    elif case == "density_len":
        kw["density"] = [1000.0]
    elif case == "density_neg":
        kw["density"] = [1000.0, -5.0]
    elif case == "radius":
        net = zero_net(particle_radius=0.05)
    with pytest.raises(DcdcError) as e:
        NeuralSimulator(net, sy, **kw)
    assert "\n" not in str(e.value)


def _stop(sim, n=20):
    with pytest.raises(RolloutStopped) as e:
        for _ in range(n):
            sim.step()
    return e.value


def test_guard_speed_domain_nan():
    sy = box_system([[0, 1.0], [0.2, 1.0]], [[0, 0], [60.0, 0]])
    e = _stop(NeuralSimulator(zero_net(), sy))
    assert (e.cause, e.particle, e.step) == ("speed", 1, 1)
    sy = box_system([[0, 1.0], [0.9, 1.0]], [[0, 0], [5.0, 0]])
    e = _stop(NeuralSimulator(zero_net(), sy))
    assert e.cause == "domain" and e.particle == 1 and e.step == 2  # 0.9 + 0.1 + 0.1 > 1
    net = zero_net()
    net.denses[-1].bias.data[:] = float("nan")
    e = _stop(NeuralSimulator(net, box_system([[0, 1.0]], [[0, 0]])))
    assert e.cause == "nan" and "step 1" in str(e) and "\n" not in str(e)


def test_guard_walls_and_penetration_count():
    # particle 1 falls through the floor at 3 m/s: inside the wall shell after 2 steps
    x = [[0.0, 1.0], [0.3, 0.12]]
    v = [[0.0, 0.0], [0.0, -3.0]]
    e = _stop(NeuralSimulator(zero_net(), box_system(x, v), guard=Guard(max_in_walls=0.0),
                              contact=False))
    assert e.cause == "walls" and e.particle == 1
    sim = NeuralSimulator(zero_net(), box_system(x, v), guard=Guard(max_in_walls=1.0),
                          contact=False)
    ro = run(sim, 3)
    assert ro.stopped is None and ro.steps == 3
    assert ro.in_walls.tolist()[0] == 0 and ro.in_walls.max() == 1
    assert ro.contacts.tolist() == [0, 0, 0]
    assert ro.entered_walls == 1
    # it keeps falling, out of the floor's underside: still counted once as having entered
    sim = NeuralSimulator(zero_net(), box_system(x, v), guard=Guard(max_in_walls=1.0,
                                                                    check_domain=False),
                          contact=False)
    ro = run(sim, 12)
    assert ro.in_walls[-1] == 0 and sim.system.x[1, 1] < -0.2 and ro.entered_walls == 1


def test_wall_contact_stops_a_particle_at_the_floor():
    # the same fall with the wall contact: caught at the floor, r/2 above its surface
    # (y = 0.0125 + r/2 above the top wall row at y = 0), its velocity into the floor removed
    x = [[0.0, 1.0], [0.3, 0.12]]
    v = [[0.0, 0.0], [0.0, -3.0]]
    sim = NeuralSimulator(zero_net(), box_system(x, v), guard=Guard(max_in_walls=0.0))
    ro = run(sim, 3)
    assert ro.stopped is None and ro.in_walls.max() == 0
    assert ro.contacts.tolist() == [0, 1, 0]  # caught in step 2; step 3 falls 2 mm from rest
    surface = 0.025  # the wall rows are the lattice cells of side 2r below y = r
    y = ro.position[2, 1, 1]
    assert surface + 0.4 * 0.025 < y < surface + 0.6 * 0.025
    assert ro.velocity[2, 1, 1] == pytest.approx(0.0, abs=1e-6)  # inelastic
    assert ro.position[:, 0] == pytest.approx(run(NeuralSimulator(
        zero_net(), box_system(x, v), guard=Guard(max_in_walls=1.0), contact=False),
        3).position[:, 0])  # the other particle is untouched


@pytest.mark.slow
def test_wall_contact_never_catches_fluid_at_rest():
    # the lattice next to a wall, corners included, stays below the catch level (2-D, 3-D)
    from dcdc.evaluate.rollout import WallContact
    from dcdc.scene import get_scene

    for dim in (2, 3):
        sy = get_scene("dam_break").realize(dim=dim, frames=2)
        c = WallContact(sy)
        psi, _ = c.map.sample(sy.x)
        assert c.target < psi.max() < c.limit  # corner particles come closest
        x, v = sy.x.copy(), sy.v.copy()
        assert c.apply(x, v) == 0 and (x == sy.x).all()


def test_contact_step_is_bounded_deep_in_a_solid():
    # deep inside a thick solid ∇Ψ -> 0: the Newton step moves at most h/4 per iteration
    from dcdc.evaluate.rollout import WallContact

    sy = box_system([[0.0, 1.0]], [[0.0, 0.0]])
    c = WallContact(sy)
    x = np.array([[0.0, -0.06]])  # 2.4 r below the floor's surface, in its third row
    v = np.zeros((1, 2))
    assert c.apply(x, v) == 1
    assert np.isfinite(x).all() and abs(x[0, 1] + 0.06) <= 3 * c.map.h / 4 + 1e-12


def test_run_records_the_stop_and_keeps_good_frames():
    sy = box_system([[0, 1.0], [0.9, 1.0]], [[0, 0], [5.0, 0]])
    ro = run(NeuralSimulator(zero_net(), sy), 10)
    assert ro.stopped is not None and ro.stopped.cause == "domain"
    assert ro.steps == 1 and ro.position.shape == (2, 2, 2)
    assert ro.time == pytest.approx([0.0, 0.02])


def test_frames_that_cannot_fit_are_refused_before_allocating():
    sim = NeuralSimulator(zero_net(), box_system([[0, 1.0]], [[0, 0]]))
    with pytest.raises(DcdcError, match="GiB"):
        run(sim, 10 ** 12)
    assert sim.steps == 0


def test_starts_from_a_dataset_frame():
    traj = Dataset(SAMPLE)[0]
    # ballistic, some particles fly into and through the walls: only NaN/speed guard here
    sim = NeuralSimulator(zero_net(), traj.system(10), time=float(traj.time[10]),
                          guard=Guard(max_in_walls=1.0, check_domain=False), contact=False)
    ro = run(sim, 2)
    assert ro.steps == 2 and ro.time == pytest.approx(traj.time[10:13])
    x2, _ = ballistic(traj.position[10], traj.velocity[10], 2)
    assert ro.position[0] == pytest.approx(traj.position[10])
    assert ro.position[2] == pytest.approx(x2, abs=1e-5)


# ---------------------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def ckpts(tmp_path_factory):
    d = tmp_path_factory.mktemp("ck")
    torch.manual_seed(0)
    save_checkpoint(d / "m2.pt", build_network("cconv", 2))
    save_checkpoint(d / "m3.pt", build_network("cconv", 3))
    save_checkpoint(d / "zero.pt", zero_net())
    return d


def test_simulate_dataset_writes_the_dataset_layout(ckpts, tmp_path, capsys):
    out = tmp_path / "r.h5"
    traj = Dataset(SAMPLE)[0]
    args = ["simulate", "--model", str(ckpts / "m2.pt"), "--dataset", SAMPLE, "--trajectory",
            traj.name, "--steps", "3", "--max-in-walls", "1", "--out", str(out)]
    assert _cli(args, capsys)[0] == 0
    ds = Dataset(out)
    r = ds[traj.name]
    assert r.n_frames == 4 and r.n_particles == traj.n_particles
    assert r.position[0] == pytest.approx(traj.position[0])
    assert (r.phase == traj.phase).all() and r.wall_x.shape == traj.wall_x.shape
    assert r.attrs["solver"].startswith("dcdc.neural") and r.attrs["split"] == "rollout"
    stats = json.loads(r.attrs["solver_stats"])
    assert stats["steps"] == 3 and len(stats["in_walls"]) == 3 and stats["stopped"] == ""
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp file left
    assert r.attrs["gemm_precision"] == "float32"
    code, _, err = _cli(args, capsys)  # exists: refused without --overwrite
    assert code == 2 and err.startswith("error:") and "--overwrite" in err
    # --bf16: the same rollout to bf16's precision (well below a millimetre in 3 steps)
    assert _cli([*args, "--overwrite", "--bf16"], capsys)[0] == 0
    b = Dataset(out)[traj.name]
    assert b.attrs["gemm_precision"] == "bf16"
    dev = np.abs(b.position[-1] - r.position[-1]).max()
    assert 0 < dev < 1e-3


def test_simulate_scene_guard_stop_is_written_and_reported(ckpts, tmp_path, capsys):
    out = tmp_path / "fall.h5"
    code, _, err = _cli(["simulate", "--model", str(ckpts / "zero.pt"), "--scene", "dam_break",
                         "--dim", "2", "--steps", "200", "--max-in-walls", "0", "--no-contact",
                         "--out", str(out)], capsys)
    # the ballistic (untrained, zero) model lets the column fall into the floor
    report = err.strip().split("\n")[-1]  # after the progress bar
    assert code == 2 and report.startswith("error: neural rollout stopped at step")
    assert "inside a wall" in report and err.count("error:") == 1
    with h5py.File(out) as f:
        g = f[next(iter(f))]
        stats = json.loads(g.attrs["solver_stats"])
        assert stats["stop_cause"] == "walls" and stats["stop_step"] == g["position"].shape[0]
        # the file says it is partial: its status, the steps asked and done, the reason
        assert g.attrs["rollout_status"] == "stopped" and int(g.attrs["steps_requested"]) == 200
        assert int(g.attrs["steps"]) == g["position"].shape[0] - 1
        assert str(g.attrs["stopped"]) in report
    s = Dataset(out).summary()
    assert s["stopped_rollouts"] == [next(iter(h5py.File(out)))]
    code, stdout, _ = _cli(["dataset", "info", str(out)], capsys)
    assert code == 0 and "PARTIAL rollouts stopped by the guard" in stdout


def test_simulate_stopped_before_its_first_step_writes_nothing(ckpts, tmp_path, capsys):
    """A rollout the guard stops at step 1 (here: every particle faster than the bound from
    the start) leaves no file behind, only the one-line reason."""
    out = tmp_path / "none.h5"
    code, _, err = _cli(["simulate", "--model", str(ckpts / "zero.pt"), "--scene", "dam_break",
                         "--dim", "2", "--steps", "5", "--max-speed", "1e-9", "--out", str(out)],
                        capsys)
    assert code == 2 and err.strip().split("\n")[-1].startswith("error: neural rollout stopped at step 1")
    assert not out.exists() and not list(tmp_path.iterdir())


def test_simulate_settle_starts_from_the_scenes_sph_state(ckpts, tmp_path, capsys):
    """--settle T: the network starts from the scene's own SPH solver state at T."""
    from dcdc.scene import get_scene
    from dcdc.sph import Simulator

    out = tmp_path / "settled.h5"
    code, _, err = _cli(["simulate", "--model", str(ckpts / "zero.pt"), "--scene", "dam_break",
                         "--dim", "2", "--resolution", "0.4", "--settle", "0.04", "--steps", "2",
                         "--max-in-walls", "1", "--out", str(out)], capsys)
    assert code == 0, err
    r = Dataset(out)[0]
    assert r.n_frames == 3 and r.time[0] == pytest.approx(0.04)
    assert float(r.attrs["settled_by_sph_s"]) == pytest.approx(0.04)
    sc = get_scene("dam_break")
    sy = sc.realize(dim=2, resolution=0.4, frames=3)
    x0 = sy.x.copy()
    sph = Simulator(sy, sc.check_solver())
    sph.advance(0.02)
    sph.advance(0.02)
    assert np.abs(sy.x - x0).max() > 1e-4  # the SPH frames moved the fluid
    assert r.position[0] == pytest.approx(sy.x, abs=1e-6)
    assert r.velocity[0] == pytest.approx(sy.v, abs=1e-5)


@pytest.mark.parametrize("args,msg", [
    (["--dataset", SAMPLE, "--trajectory", "random_0_2d", "--settle", "0.2"], "--settle"),
    (["--scene", "dam_break", "--dim", "2", "--settle", "0.03"], "multiple"),
    (["--scene", "dam_break", "--dim", "2", "--settle", "-1"], "> 0"),
    (["--scene", "dam_break", "--dataset", SAMPLE], "exactly one"),
    (["--dataset", SAMPLE], "--trajectory"),
    (["--dataset", SAMPLE, "--trajectory", "random_0_2d", "--dim", "2"], "--dim"),
    (["--dataset", SAMPLE, "--trajectory", "random_0_2d", "--steps", "0"], "--steps"),
    (["--dataset", SAMPLE, "--trajectory", "nope"], "no trajectory"),
])
def test_simulate_bad_arguments(ckpts, tmp_path, capsys, args, msg):
    code, _, err = _cli(["simulate", "--model", str(ckpts / "m2.pt"), *args, "--out",
                         str(tmp_path / "x.h5")], capsys)
    assert code == 2 and err.startswith("error:") and msg in err and err.count("\n") == 1


def test_simulate_3d_model_on_2d_data(ckpts, tmp_path, capsys):
    code, _, err = _cli(["simulate", "--model", str(ckpts / "m3.pt"), "--dataset", SAMPLE,
                         "--trajectory", "random_0_2d", "--out", str(tmp_path / "x.h5")], capsys)
    assert code == 2 and "3-D" in err and "2-D" in err
    assert not (tmp_path / "x.h5").exists()


def test_wall_contact_catches_a_particle_that_would_jump_through_a_wall():
    # 30 m/s down from y = 0.3: one step ends at y = -0.3, below the whole floor (3 rows, down
    # to y = -0.125), where the walls' volume map is 0 again; the swept test catches it
    x, v = [[0.0, 0.3]], [[0.0, -30.0]]
    sim = NeuralSimulator(zero_net(), box_system(x, v), guard=Guard(max_in_walls=1.0,
                                                                     check_domain=False))
    sim.step()
    assert sim.stats["contacts"] == 1
    assert 0.025 < sim.system.x[0, 1] < 0.05 and sim.system.v[0, 1] >= -1e-9
    sim = NeuralSimulator(zero_net(), box_system(x, v), guard=Guard(max_in_walls=1.0,
                                                                     check_domain=False),
                          contact=False)
    sim.step()
    assert sim.system.x[0, 1] < -0.2  # the network alone: straight through
