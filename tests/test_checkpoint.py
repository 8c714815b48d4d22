"""Checkpoint integrity and model ↔ data compatibility."""
import numpy as np
import pytest
import torch

from dcdc.cli import main
from dcdc.errors import DcdcError
from dcdc.model.checkpoint import (FORMAT_VERSION, check_compatible, digest, load_checkpoint,
                                   read_checkpoint, save_checkpoint)
from dcdc.model.networks import NetConfig, build_network

SMALL = dict(channels=[8, 12, 12])


def _saved(tmp_path, name="dcdc", dim=2, **kw):
    torch.manual_seed(0)
    net = build_network(name, dim, **{**SMALL, **kw})
    return net, save_checkpoint(tmp_path / "m.pt", net, extra={"step": 3})


def _restamped(tmp_path, ck, fname="x.pt"):
    p = tmp_path / fname
    torch.save({**ck, "digest": digest(ck)}, p)
    return p


def test_flipped_bytes_in_the_weights_are_refused(tmp_path):
    net, path = _saved(tmp_path)
    raw = bytearray(path.read_bytes())
    w = net.convs[1].weight.detach().numpy().tobytes()  # the largest tensor
    at = bytes(raw).find(w)
    assert at > 0  # torch.save stores tensors uncompressed
    for k in range(20):  # 20 flipped bits spread over the tensor
        raw[at + 37 * k + 3] ^= 1 << (k % 8)
    path.write_bytes(bytes(raw))
    with pytest.raises(DcdcError, match="damaged: its contents do not match the stored digest"):
        load_checkpoint(path)


def test_digest_covers_weights_config_and_extra(tmp_path):
    net, path = _saved(tmp_path)
    ck = torch.load(path, weights_only=True)
    assert ck["digest"] == digest(ck)
    for change in ({"config": {**ck["config"], "rho_ref": 999.0}},
                   {"extra": {"step": 4}},
                   {"state_dict": {**ck["state_dict"],
                                   "dense0.bias": ck["state_dict"]["dense0.bias"] + 1e-6}}):
        p = tmp_path / "changed.pt"
        torch.save({**ck, **change}, p)  # the old digest kept
        with pytest.raises(DcdcError, match="do not match the stored digest"):
            read_checkpoint(p)
    p = tmp_path / "nodigest.pt"
    torch.save({k: v for k, v in ck.items() if k != "digest"}, p)
    with pytest.raises(DcdcError, match="no digest"):
        read_checkpoint(p)


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_weights_are_refused(tmp_path, bad):
    net, path = _saved(tmp_path)
    ck = torch.load(path, weights_only=True)
    sd = dict(ck["state_dict"])
    sd["dense0.weight"] = sd["dense0.weight"].clone()
    sd["dense0.weight"][0, 0] = bad
    with pytest.raises(DcdcError, match="dense0.weight.*NaN or inf"):
        load_checkpoint(_restamped(tmp_path, {**ck, "state_dict": sd}))


def test_text_file_and_old_version_are_one_line_errors(tmp_path, capsys):
    txt = tmp_path / "notes.pt"
    txt.write_text("hello, this is not a checkpoint\n" * 3)
    with pytest.raises(DcdcError, match="corrupt or not a dcdc checkpoint .not a PyTorch zip"):
        load_checkpoint(txt)
    _, path = _saved(tmp_path)
    ck = torch.load(path, weights_only=True)
    with pytest.raises(DcdcError, match=f"format version 1; .* reads version {FORMAT_VERSION}"):
        load_checkpoint(_restamped(tmp_path, {**ck, "format_version": 1}))


@pytest.mark.parametrize("change, msg", [
    ({"channels": [-8, 12, 12]}, "channels must be a non-empty list of positive integers"),
    ({"channels": []}, "channels must be a non-empty list"),
    ({"kernel_size": "4"}, "kernel_size must be an integer"),
    ({"kernel_size": 4.0}, "kernel_size must be an integer"),
    ({"rho_ref": -1000.0}, "rho_ref must be > 0"),
    ({"particle_radius": 0.0}, "particle_radius must be > 0"),
    ({"frame_dt": float("nan")}, "frame_dt must be a finite number"),
    ({"density_mode": "fast"}, "density_mode must be one of auto, classes, edges"),
    ({"normalize": 1}, "normalize must be true or false"),
    ({"layers": 3}, "unknown network option"),
])
def test_invalid_config_in_a_checkpoint_is_one_line(tmp_path, change, msg):
    _, path = _saved(tmp_path)
    ck = torch.load(path, weights_only=True)
    bad = _restamped(tmp_path, {**ck, "config": {**ck["config"], **change}})
    with pytest.raises(DcdcError, match=msg) as e:
        load_checkpoint(bad)
    assert "\n" not in str(e.value) and str(bad) in str(e.value)


def test_cli_prints_one_line_for_a_text_checkpoint(tmp_path, capsys):
    """Through the CLI's error path (any verb that loads a checkpoint ends the same way)."""
    import click

    @click.command()
    @click.argument("path")
    def probe(path):
        load_checkpoint(path)

    from dcdc import cli as cli_mod
    cli_mod.cli.add_command(probe, "probe-checkpoint")
    try:
        txt = tmp_path / "t.pt"
        txt.write_text("e" * 200)
        with pytest.raises(SystemExit) as e:
            main(["probe-checkpoint", str(txt)])
        assert e.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith("error: checkpoint") and err.count("\n") == 1
    finally:
        cli_mod.cli.commands.pop("probe-checkpoint", None)


# ---------------------------------------------------------------------- compatibility
def test_config_carries_radius_and_dt_and_derives_the_conv_radius(tmp_path):
    net, path = _saved(tmp_path, particle_radius=0.0125, frame_dt=0.01)
    assert net.cfg.radius == pytest.approx(4.5 * 0.0125)
    model, ck = load_checkpoint(path)
    assert ck["config"]["particle_radius"] == 0.0125 and ck["config"]["frame_dt"] == 0.01
    assert model.cfg.radius == pytest.approx(0.05625)
    # default dt of a step is the model's frame_dt
    from dcdc.model.integrator import step
    x = np.random.default_rng(0).uniform(0, 0.1, (20, 2))
    v = np.zeros_like(x)
    a, _ = step(model, x, v, np.full(20, 1000.0))
    b, _ = step(model, x, v, np.full(20, 1000.0), dt=0.01)
    torch.testing.assert_close(a, b)


def test_check_compatible(tmp_path):
    net, path = _saved(tmp_path, dim=2)
    ck = read_checkpoint(path)
    for cfg in (net, ck, ck["config"]):
        check_compatible(cfg, dim=2, radius=np.float32(0.025), frame_dt=0.02)  # float32 attrs ok
        with pytest.raises(DcdcError, match="the model is 2-D but dataset D is 3-D"):
            check_compatible(cfg, dim=3, what="dataset D")
        with pytest.raises(DcdcError, match="particle radius 0.025 m but the data has 0.0125 m"):
            check_compatible(cfg, radius=0.0125)
        with pytest.raises(DcdcError, match="dt = 0.02 s but the data has frames every 0.01 s"):
            check_compatible(cfg, frame_dt=0.01)
    check_compatible(NetConfig(), radius=0.025, frame_dt=0.02)


def test_cconv_without_density_input_is_the_dlf_layout():
    plain = build_network("cconv", 3, density_input=False)
    assert plain.config()["density_input"] is False
    assert plain.conv0_fluid.weight.shape[1] == 4  # [1, v]: DeepLagrangianFluids' input
    assert build_network("cconv", 3).conv0_fluid.weight.shape[1] == 5  # + log(1 + ρ/ρ_ref)
    assert build_network("dcdc", 3).config()["density_input"] is False


def test_shipped_models_load_by_name_and_match_their_card():
    """The pretrained checkpoints in dcdc/assets/models load by bare name (docs/models.md);
    a name that is neither a file nor a shipped model says which models are shipped."""
    from dcdc.errors import DcdcError
    from dcdc.model.checkpoint import load_checkpoint, shipped_models

    shipped = shipped_models()
    networks = {"dcdc2d": ("dcdc", 2), "cconv2d": ("cconv", 2), "antisym2d": ("dcdc-antisym", 2),
                "dcdc3d": ("dcdc", 3), "cconv3d": ("cconv", 3)}
    assert set(networks) <= set(shipped)
    for name, (network, dim) in networks.items():
        net, ck = load_checkpoint(name)
        assert net.name == network and net.dim == dim and ck["data"]["dim"] == dim
        assert ck["extra"]["step"] == ck["extra"]["train_config"]["optim"]["steps"]
        assert abs(net.cfg.particle_radius - 0.025) < 1e-12 and abs(net.cfg.frame_dt - 0.02) < 1e-12
    with pytest.raises(DcdcError, match="shipped models: .*dcdc2d"):
        load_checkpoint("no_such_model")
