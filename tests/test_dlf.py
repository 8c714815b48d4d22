"""dcdc.model.dlf: DeepLagrangianFluids' weights as a dcdc network, their scenes, import-dlf."""
import json
from pathlib import Path

import numpy as np
import pytest
import torch

from dcdc.cli import main
from dcdc.errors import DcdcError
from dcdc.evaluate.rollout import Guard, NeuralSimulator, run
from dcdc.model import dlf
from dcdc.scene.importers.dlf import scene_system
from dcdc.model.cconv import build_geometry, cconv
from dcdc.model.checkpoint import load_checkpoint
from dcdc.model.integrator import step

# the project's shared/ folder lies beside the checkout (CI lays a copy there)
ANCHOR = next((p for p in (Path(__file__).resolve().parents[2] / "shared/anchors/dlf",
                           Path("/work/shared/anchors/dlf")) if p.is_dir()),
              Path("/work/shared/anchors/dlf"))
WEIGHTS = ANCHOR / "pretrained_model_weights.pt"
needs_weights = pytest.mark.skipif(not WEIGHTS.exists(), reason="DLF anchor weights not present")


def random_dlf_weights(seed=0):
    g = torch.Generator().manual_seed(seed)
    sd = {k: 0.3 * torch.randn(s, generator=g) for k, s in dlf.SHAPES.items()}
    for c in ("conv0_fluid", "conv0_obstacle", "conv1", "conv2", "conv3"):
        sd[f"{c}.offset"] = torch.zeros(3)
    sd["gravity"] = torch.tensor([0.0, -9.81, 0.0])
    return sd


def dlf_reference_step(sd, pos, vel, box, box_n, dt=0.02):
    """Their MyParticleNetwork.forward written out in their layout (features concatenated
    [obstacle, fluid, dense], open3d [z, y, x, in, out] filters) on dcdc's CConv operator."""
    R = 0.1125
    g = torch.tensor([0.0, -9.81, 0.0], dtype=torch.float64)
    v2 = vel + dt * g
    p2 = pos + dt * (v2 + vel) / 2
    gf = build_geometry(p2.numpy(), None, R, 4, True, False)
    gw = build_geometry(p2.numpy(), box.numpy(), R, 4, False, False)

    def conv(name, f, geom):
        k = sd[f"{name}.kernel"].double()
        return cconv(f, k.reshape(64, k.shape[3], k.shape[4]), geom) + sd[f"{name}.bias"].double()

    def dense(name, f):
        return f @ sd[f"{name}.weight"].double().T + sd[f"{name}.bias"].double()

    f = torch.cat([torch.ones(len(pos), 1, dtype=torch.float64), v2], 1)
    h = torch.cat([conv("conv0_obstacle", box_n, gw), conv("conv0_fluid", f, gf),
                   dense("dense0_fluid", f)], 1)
    for i in (1, 2, 3):
        a = torch.relu(h)
        out = conv(f"conv{i}", a, gf) + dense(f"dense{i}", a)
        h = out + h if out.shape == h.shape else out
    pos_new = p2 + h / 128
    return pos_new, (pos_new - pos) / dt


def _blob(n=60, m=80, seed=1):
    rng = np.random.default_rng(seed)
    pos = torch.as_tensor(rng.uniform(-0.15, 0.15, (n, 3)))
    vel = torch.as_tensor(rng.normal(0, 0.5, (n, 3)))
    box = torch.as_tensor(np.c_[rng.uniform(-0.2, 0.2, m), np.full(m, -0.17), rng.uniform(-0.2, 0.2, m)])
    box_n = torch.tensor([[0.0, 1.0, 0.0]]).repeat(m, 1).double()
    return pos, vel, box, box_n


def test_converted_network_equals_their_forward_pass():
    sd = random_dlf_weights()
    net = dlf.convert(sd).double()
    assert net.name == "cconv" and net.dim == 3 and not net.density_input
    assert net.cfg.radius == pytest.approx(0.1125) and net.cfg.frame_dt == pytest.approx(0.02)
    pos, vel, box, box_n = _blob()
    ours = step(net, pos, vel, np.full(len(pos), 1000.0), box, box_n)
    ref = dlf_reference_step(sd, pos, vel, box, box_n)
    for a, b in zip(ours, ref):
        assert torch.allclose(a, b, atol=1e-10, rtol=1e-9)
    # the fluid/obstacle order of the first layer matters: swapping it changes the result
    sd2 = dict(sd)
    sd2["dense1.weight"] = torch.cat([sd["dense1.weight"][:, 32:64], sd["dense1.weight"][:, :32],
                                      sd["dense1.weight"][:, 64:]], 1)
    assert not torch.allclose(step(dlf.convert(sd2).double(), pos, vel, np.full(len(pos), 1e3),
                                   box, box_n)[0], ours[0])


@pytest.mark.parametrize("case,msg", [
    ("missing", "lacks conv3.kernel"), ("shape", "has shape"), ("offset", "offset"),
    ("nan", "NaN"), ("gravity", "gravity"), ("text", "not a torch state_dict"),
])
def test_bad_weights_are_one_line_errors(tmp_path, case, msg):
    sd = random_dlf_weights()
    if case == "missing":
        del sd["conv3.kernel"]
    elif case == "shape":
        sd["conv1.kernel"] = torch.zeros(3, 3, 3, 96, 64)
    elif case == "offset":
        sd["conv2.offset"] = torch.tensor([0.0, 0.1, 0.0])
    elif case == "nan":
        sd["dense2.bias"][0] = float("nan")
    elif case == "gravity":
        sd["gravity"] = torch.tensor([0.0, -1.62, 0.0])
    p = tmp_path / "w.pt"
    if case == "text":
        p.write_text("not weights\n")
    else:
        torch.save(sd, p)
    with pytest.raises(DcdcError, match=msg) as e:
        dlf.read_weights(p)
    assert "\n" not in str(e.value)


def _cube_obj(path, lo, hi):
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = [(x0, y0, z1), (x0, y1, z1), (x0, y0, z0), (x0, y1, z0),
         (x1, y0, z1), (x1, y1, z1), (x1, y0, z0), (x1, y1, z0)]
    f = [(2, 3, 1), (4, 7, 3), (8, 5, 7), (6, 1, 5), (7, 1, 3), (4, 6, 8),
         (2, 4, 3), (4, 8, 7), (8, 6, 5), (6, 2, 1), (7, 5, 1), (4, 2, 6)]
    path.write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v) +
                    "".join(f"f {a} {b} {c}\n" for a, b, c in f))


@pytest.fixture
def small_scene(tmp_path):
    """Their JSON format: a 0.8 × 1 × 0.8 m box and a 0.3 m fluid cube emitted twice."""
    _cube_obj(tmp_path / "box.obj", (-0.4, 0, -0.4), (0.4, 1.0, 0.4))
    _cube_obj(tmp_path / "fluid.obj", (-0.15, -0.15, -0.15), (0.15, 0.15, 0.15))
    scene = {"walls": [{"path": "../models/box.obj", "translation": [0, 0, 0]}],
             "fluids": [{"path": "fluid.obj", "velocity": [0.3, 0, 0.2],
                         "translation": [0, 0.4, 0], "start": 0, "stop": 40, "step": 30}]}
    p = tmp_path / "scene.json"
    p.write_text(json.dumps(scene))
    return p


def test_scene_system_samples_their_scene(small_scene):
    sy = scene_system(small_scene, frames=100)
    assert sy.dim == 3 and sy.n_fluid == 2 * 6 ** 3  # emitted at steps 0 and 30
    assert sorted(set(np.round(sy.birth, 6))) == [0.0, 0.6]
    assert np.allclose(sy.v, [0.3, 0, 0.2])
    assert (np.abs(sy.x[:, [0, 2]]) < 0.15).all() and (np.abs(sy.x[:, 1] - 0.4) < 0.15).all()
    # walls on the box surface at 1.9 / (π r²) per m² (a whole number of grid rows per
    # face: 5 % fewer on this small box), normals pointing into the box
    area = 4 * 0.8 * 1.0 + 2 * 0.8 * 0.8
    assert sy.n_wall == pytest.approx(1.9 * area / (np.pi * 0.025 ** 2), rel=0.06)
    assert np.allclose(np.abs(sy.wall_x).max(0), [0.4, 1.0, 0.4])
    inward = ((np.array([0, 0.5, 0]) - sy.wall_x) * sy.wall_n).sum(1)
    assert (inward > 0).all() and np.allclose(np.linalg.norm(sy.wall_n, axis=1), 1)
    bad = small_scene.with_name("bad.json")
    bad.write_text(small_scene.read_text().replace("fluid.obj", "gone.obj"))
    with pytest.raises(DcdcError, match="gone.obj of the scene not found"):
        scene_system(bad)


@pytest.mark.slow
@needs_weights
def test_pretrained_network_keeps_the_fluid_in_a_box(small_scene):
    """A short version of the 500-step example-scene check of docs/evaluation.md: the
    published weights, converted, hold two emitted fluid cubes in a closed box."""
    net = dlf.convert(dlf.read_weights(WEIGHTS))
    sy = scene_system(small_scene, frames=60)
    ro = run(NeuralSimulator(net, sy, guard=Guard(max_in_walls=0.0)), 60)
    assert ro.stopped is None and ro.steps == 60 and ro.in_walls.max() == 0
    x = ro.position[-1]
    assert (x[:, 1] > 0).all() and (np.abs(x[:, [0, 2]]) < 0.4).all()
    assert np.abs(ro.velocity[-1]).max() < 3.0  # settling, no explosion


@needs_weights
def test_import_dlf_cli(tmp_path, capsys):
    out = tmp_path / "dlf.pt"
    main(["model", "import-dlf", str(WEIGHTS), "-o", str(out)])
    assert "cconv" in capsys.readouterr().out
    net, ck = load_checkpoint(out, expect="cconv", dim=3)
    assert not net.density_input and "CDLA" in ck["data"]["license"]
    with pytest.raises(SystemExit) as e:  # exists
        main(["model", "import-dlf", str(WEIGHTS), "-o", str(out)])
    assert e.value.code == 2


def test_matches_open3d_forward_pass():
    """Optional oracle: their network built from open3d's ContinuousConv (as in their
    models/default_torch.py) and ours give the same step on the same weights."""
    ml3d = pytest.importorskip("open3d.ml.torch")
    sd = random_dlf_weights(3)
    pos, vel, box, box_n = (t.float() for t in _blob())

    def layer(cin, cout, name):
        conv = ml3d.layers.ContinuousConv(
            kernel_size=[4, 4, 4], activation=None, align_corners=True, interpolation="linear",
            coordinate_mapping="ball_to_cube_volume_preserving", normalize=False,
            window_function=lambda r2: torch.clamp((1 - r2) ** 3, 0, 1),
            radius_search_ignore_query_points=True, in_channels=cin, filters=cout)
        conv.kernel.data = sd[f"{name}.kernel"].float().clone()
        conv.bias.data = sd[f"{name}.bias"].float().clone()
        return conv

    def lin(name):
        return lambda f: f @ sd[f"{name}.weight"].float().T + sd[f"{name}.bias"].float()

    ext = torch.tensor(0.225)
    v2 = vel + 0.02 * torch.tensor([0.0, -9.81, 0.0])
    p2 = pos + 0.02 * (v2 + vel) / 2
    f = torch.cat([torch.ones(len(pos), 1), v2], 1)
    h = torch.cat([layer(3, 32, "conv0_obstacle")(box_n, box, p2, ext),
                   layer(4, 32, "conv0_fluid")(f, p2, p2, ext), lin("dense0_fluid")(f)], 1)
    for i, (a, b) in enumerate([(96, 64), (64, 64), (64, 3)], start=1):
        r = torch.relu(h)
        out = layer(a, b, f"conv{i}")(r, p2, p2, ext) + lin(f"dense{i}")(r)
        h = out + h if out.shape == h.shape else out
    theirs = p2 + h / 128
    ours, _ = step(dlf.convert(sd), pos, vel, np.full(len(pos), 1000.0), box, box_n)
    assert torch.allclose(ours, theirs, atol=1e-5)
