"""Smoke tests of ``dcdc benchmark cconv`` / ``dcdc benchmark model`` (tiny sizes; no timing asserts)."""
import json

from click.testing import CliRunner

from dcdc.model.benchmark import cconv_command, model_command, tank


def test_cconv_benchmark_cli_writes_json(tmp_path):
    out = tmp_path / "cconv.json"
    res = CliRunner().invoke(cconv_command, ["--particles", "1000", "--channels", "8",
                                             "--repeat", "1", "--torch-backend", "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert [r["variant"] for r in data["rows"]] == ["numba fp32", "torch fp32",
                                                    "numba bf16 GEMM (inference)"]
    assert data["setup"]["mean_neighbors"] > 20
    assert all(r["fwd_s"] > 0 for r in data["rows"])


def test_model_benchmark_cli_writes_json(tmp_path):
    out = tmp_path / "model.json"
    res = CliRunner().invoke(model_command, ["--particles", "400", "--repeat", "1",
                                             "--json", str(out)])
    assert res.exit_code == 0, res.output
    rows = json.loads(out.read_text())["rows"]
    assert {r["network"] for r in rows} == {"dcdc", "cconv", "dcdc-antisym"}
    assert all(r["ms_per_step"] > 0 and r["search_ms"] >= 0 for r in rows)


def test_tank_scene_walls_face_the_fluid():
    x, v, rho, wx, wn = tank(1000)
    assert len(x) == 1000 and set(rho) == {1000.0, 2000.0}
    centre = x.mean(0)
    assert ((centre - wx) * wn).sum(1).min() > 0  # normals point into the tank


def test_model_benchmark_training_step(tmp_path):
    res = CliRunner().invoke(model_command, ["--particles", "300", "--networks", "dcdc",
                                             "--repeat", "1", "--train"])
    assert res.exit_code == 0, res.output
    assert "training step" in res.output


def test_train_benchmark_cli_writes_json(tmp_path):
    from dcdc.train.benchmark import train_benchmark_command

    out = tmp_path / "train.json"
    res = CliRunner().invoke(train_benchmark_command, ["--quick", "--repeat", "1",
                                                       "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert [(r["network"], r["dim"]) for r in data["rows"]] == [
        ("dcdc", 2), ("cconv", 2), ("dcdc", 3), ("cconv", 3)]
    assert all(r["particle_steps_per_s"] > 0 and r["unroll"] == 2 for r in data["rows"])
    assert set(data["ratios"]) == {"2d_dcdc_over_cconv", "2d_dcdc_over_cconv_cpu",
                                   "3d_dcdc_over_cconv", "3d_dcdc_over_cconv_cpu"}


def test_model_benchmark_network_options_and_scaling(tmp_path):
    """--kernel-size/--channels reach the network; two sizes give a fitted scaling exponent;
    the breakdown (search, geometry, convolutions) stays in every row."""
    out = tmp_path / "model.json"
    res = CliRunner().invoke(model_command, ["--particles", "200,400", "--networks", "dcdc",
                                             "--repeat", "1", "--kernel-size", "3",
                                             "--channels", "8,8", "--json", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert all(r["options"] == {"kernel_size": 3, "channels": [8, 8]} for r in data["rows"])
    assert all(r["search_ms"] > 0 and r["geometry_ms"] > 0 and r["convolutions_ms"] > 0
               for r in data["rows"])
    assert set(data["scaling"]) == {"dcdc"} and "scaling dcdc" in res.output
    bad = CliRunner().invoke(model_command, ["--particles", "200", "--channels", "a,b"])
    assert bad.exit_code != 0 and "--channels" in str(bad.exception or bad.output)


def test_model_benchmark_radius_scale_reaches_the_network(tmp_path):
    """--radius-scale sets the convolution radius: the mean neighbour count of the jittered
    lattice falls with the radius's cube (2.25 → 1.5 spacings: about 0.3×)."""
    counts = {}
    for scale in (4.5, 3.0):
        out = tmp_path / f"m{scale}.json"
        res = CliRunner().invoke(model_command, ["--particles", "2000", "--networks", "dcdc",
                                                 "--repeat", "1", "--channels", "8,8",
                                                 "--radius-scale", str(scale), "--json", str(out)])
        assert res.exit_code == 0, res.output
        row = json.loads(out.read_text())["rows"][0]
        assert row["options"]["radius_scale"] == scale
        counts[scale] = row["neighbours_mean"]
    assert 0.2 < counts[3.0] / counts[4.5] < 0.45
    bad = CliRunner().invoke(model_command, ["--particles", "200", "--radius-scale", "0"])
    assert bad.exit_code != 0 and "--radius-scale" in str(bad.exception or bad.output)
