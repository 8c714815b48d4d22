"""SPlisHSPlasH's own multiphase scene in dcdc: the importer applies what SPlisHSPlasH
applies (its default viscosity method and coefficient, the particle counts of its fluid
blocks, its emitter cap) or names the difference, and the cross-check runner
(``python -m dcdc.sph.splishsplash``) resolves the scene path, finds SPlisHSPlasH's data
from a virtual environment and reads volume-map boundaries. No test here needs
SPlisHSPlasH to run except the one marked slow."""
import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from dcdc.scene import load
from dcdc.scene.importers import import_scene
from dcdc.scene.importers.splishsplash import block_counts
from dcdc.sph import splishsplash as ss

MODELS = Path(__file__).resolve().parent / "data" / "models"
needs_splash = pytest.mark.skipif(not ss.available(), reason="pysplishsplash not installed")


def imported(tmp_path, scene: dict, name="scene"):
    src = tmp_path / f"{name}.json"
    src.write_text(json.dumps(scene))
    out = tmp_path / f"{name}.toml"
    res = import_scene(src, out)
    out.write_text(res.text)
    return res, load(out)


def double_dam_break() -> dict:
    """The items of SPlisHSPlasH's DoubleDamBreakMultiPhase.json that decide what dcdc
    realises (its numbers; the tank is the test UnitBox scaled the same way)."""
    return {
        "Configuration": {"particleRadius": 0.025, "simulationMethod": 4, "boundaryHandlingMethod": 2,
                          "DFSPH": {"minIterations": 2, "maxIterations": 100, "maxError": 0.05}},
        "Materials": [
            {"id": "first_fluid", "density0": 1000, "viscosityMethod": 1,
             "Standard viscosity": {"viscosity": 0.01}},
            {"id": "second_fluid", "density0": 500, "viscosityMethod": 1,
             "Standard viscosity": {"viscosity": 0.01}},
            {"id": "third_fluid", "density0": 250, "maxEmitterParticles": 1000,
             "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": str(MODELS / "UnitBox.obj"), "translation": [0, 2, 0],
                         "scale": [2.1, 4, 2.1], "isDynamic": False, "mapInvert": True}],
        "FluidBlocks": [{"id": "first_fluid", "denseMode": 0, "start": [-1.0, 0.0, -1.0],
                         "end": [-0.3, 0.75, -0.3]},
                        {"id": "second_fluid", "denseMode": 0, "start": [0.3, 0.0, 0.3],
                         "end": [1.0, 1.75, 1.0]}],
        "Emitters": [{"id": "third_fluid", "width": 8, "height": 3, "translation": [-0.2, 0.75, 0.0],
                      "velocity": 2, "type": 0, "emitEndTime": 2}],
    }


# ------------------------------------------------------------------ viscosity
def test_default_viscosity_method_is_standard(tmp_path):
    """Without viscosityMethod SPlisHSPlasH applies method 1 (standard viscosity), with
    coefficient 0.01 when none is given; method 0 is none (dcdc's default stays)."""
    scene = {"FluidBlocks": [{"id": i, "start": [0.2 * k, 0, 0], "end": [0.2 * k + 0.15, 0.15, 0.15]}
                             for k, i in enumerate("abcde")],
             "Materials": [
                 {"id": "a", "Standard viscosity": {"viscosity": 0.02}},  # newer file, no method
                 {"id": "b"},                                            # nothing: the defaults
                 {"id": "c", "viscosityMethod": 0, "viscosity": 0.5},    # none
                 {"id": "d", "viscosity": 0.005}]}                      # older file, no method
    res, sc = imported(tmp_path, scene)
    ph = sc.data["phases"]
    assert ph["a"]["viscosity"] == 0.02 and ph["b"]["viscosity"] == 0.01
    assert ph["d"]["viscosity"] == 0.005 and ph["e"]["viscosity"] == 0.01  # e: no material at all
    assert ph["c"]["viscosity"] == 1e-6  # dcdc's default (water), not 0.5
    head = res.text.split("\nname =")[0]
    assert "Materials[0] (a): SPlisHSPlasH applies its default method (1, standard viscosity): ν = 0.02" in head
    assert "Materials[1] (b): SPlisHSPlasH applies its default method (1, standard viscosity) with its " \
           "default coefficient: ν = 0.01" in head
    assert "acts between particles of the same fluid only, dcdc's between phases too" in head
    assert not any("viscosity" in w for w in res.warnings)


def test_double_dam_break_third_fluid_keeps_its_viscosity(tmp_path):
    res, sc = imported(tmp_path, double_dam_break())
    assert {k: p["viscosity"] for k, p in sc.data["phases"].items()} == {
        "first_fluid": 0.01, "second_fluid": 0.01, "third_fluid": 0.01}
    assert "Materials[2] (third_fluid): SPlisHSPlasH applies its default method" in res.text


# ------------------------------------------------------------------ particle counts
def test_double_dam_break_has_splishsplash_particle_counts(tmp_path):
    """SPlisHSPlasH samples 2 366 and 5 746 particles in the two blocks (round(L/2r) − 1 per
    axis: 13·14·13, 13·34·13) and emits 1 000 of the third fluid; dcdc realises the same
    blocks and names the emitter's difference (whole layers: 984) and its housing."""
    res, sc = imported(tmp_path, double_dam_break())
    s = sc.realize()
    counts = s.counts_per_phase()
    assert counts["first_fluid"] == 2366 and counts["second_fluid"] == 5746
    assert counts["third_fluid"] == 984
    w = "\n".join(res.warnings)
    assert "SPlisHSPlasH emits 1000 particles (maxEmitterParticles 1000), its last layer 16 of 24; " \
           "dcdc emits whole layers: 984" in w
    assert "emitter housing (box 0.2 x 0.275 x 0.525 m" in w
    first = s.x[s.phase == 0]
    # SPlisHSPlasH's particles start 2r inside the block (y = 0.05 ... 0.70); dcdc's lattice
    # (odd multiples of r) holds as many, r nearer the block's start
    assert np.isclose(first[:, 1].min(), 0.025) and np.isclose(first[:, 1].max(), 0.675)
    assert np.isclose(first[:, 0].min(), -0.975) and np.isclose(first[:, 0].max(), -0.375)
    assert "as many particles as SPlisHSPlasH samples" in res.text


def test_block_counts_follow_splishsplash():
    r = 0.025
    assert block_counts([-1, 0, -1], [-0.3, 0.75, -0.3], r).tolist() == [13, 14, 13]
    assert block_counts([0, 0, 0], [0.1, 0.1, 0.1], r).tolist() == [1, 1, 1]  # empty there
    # C's round: 0.125 / 0.05 = 2.5 rounds up, then one less
    assert block_counts([0, 0, 0], [0.125, 0.2, 0.2], r).tolist() == [2, 3, 3]
    n1 = block_counts([0, 0, 0], [0.5, 0.5, 0.5], r, mode=1)  # y steps √3 r; x, z lose 2r
    assert n1.tolist() == [8, int(np.floor(0.5 / (np.sqrt(3) * r) + 0.5)) - 1, 8]


def test_empty_and_dense_blocks_are_named(tmp_path):
    scene = {"FluidBlocks": [{"start": [0, 0, 0], "end": [0.1, 0.5, 0.5]},
                             {"start": [0.5, 0, 0], "end": [1.0, 0.5, 0.5], "denseMode": 2}]}
    res, sc = imported(tmp_path, scene)
    w = "\n".join(res.warnings)
    assert "FluidBlocks[0]: SPlisHSPlasH samples no particles in it (1 x 9 x 9 steps" in w
    assert len(sc.data["fluid"]) == 1
    n = int(np.prod(block_counts([0.5, 0, 0], [1.0, 0.5, 0.5], 0.025, 2)))
    assert f"FluidBlocks[1]: denseMode 2 (dense) not mapped: SPlisHSPlasH samples {n} particles, " \
           "dcdc 1000 on its cubic lattice" in w


def test_shipped_double_dam_break_counts(tmp_path):
    """The scene file itself, where the installed pysplishsplash brought it."""
    root = ss.data_root()
    src = root / "data" / "Scenes" / "DoubleDamBreakMultiPhase.json" if root else None
    if src is None or not src.is_file():
        pytest.skip("SPlisHSPlasH's DoubleDamBreakMultiPhase.json not installed (pysplishsplash)")
    res = import_scene(src, tmp_path / "ddb.toml")
    (tmp_path / "ddb.toml").write_text(res.text)
    counts = load(tmp_path / "ddb.toml").realize().counts_per_phase()
    assert (counts["first_fluid"], counts["second_fluid"]) == (2366, 5746)


# ------------------------------------------------------------------ the runner
def test_runner_without_pysplishsplash_is_one_error_line(monkeypatch, capsys):
    monkeypatch.setattr(ss, "available", lambda: False)
    assert ss.main(["scene.json"]) == 2
    err = capsys.readouterr().err
    assert err == "error: pysplishsplash is not installed (pip install 'dcdc[splash]')\n"


def test_boundary_readout_without_particles():
    """Volume-map boundaries (Bender 2019) have no particles: counted as 0, named."""
    class Map:
        pass

    class Particles:
        def numberOfParticles(self):
            return 7

    models = [Map(), Particles()]
    sim = SimpleNamespace(numberOfBoundaryModels=lambda: 2, getBoundaryModel=lambda k: models[k])
    assert ss._boundary(sim) == (7, ["Map", "Particles"])


@needs_splash
def test_runner_resolves_the_scene_path(tmp_path, monkeypatch):
    """A relative scene path reaches the child absolute, whatever the working directory."""
    (tmp_path / "sub").mkdir()
    scene = tmp_path / "sub" / "s.json"
    scene.write_text("{}")
    monkeypatch.chdir(tmp_path)
    seen = {}

    def fake_run(cmd, **kw):
        seen["cmd"], seen["cwd"] = cmd, kw.get("cwd")
        return SimpleNamespace(returncode=1, stdout="", stderr="stopped\n")

    monkeypatch.setattr(ss.subprocess, "run", fake_run)
    r = ss.run_scene("sub/s.json", stop_at=0.5, times=[0.1, 0.2])
    cmd = seen["cmd"]
    assert cmd[cmd.index("--child") + 1] == str(scene.resolve())
    assert cmd[cmd.index("--stop-at") + 1] == "0.5" and cmd[cmd.index("--times") + 1] == "0.1,0.2"
    assert seen["cwd"] != str(tmp_path) and r["status"].startswith("crashed (exit 1) stopped")
    with pytest.raises(ss.DcdcError, match="no such scene file"):
        ss.run_scene("sub/missing.json")


@needs_splash
def test_child_interpreter_finds_splishsplash_data(tmp_path):
    """The child's executable has SPlisHSPlasH's resources/ beside it (a copy of the
    interpreter where the real one lacks them, as in a virtual environment) and imports
    dcdc."""
    root = ss.data_root()
    if root is None:
        pytest.skip("the installed pysplishsplash lists no resources/")
    exe, extra = ss.interpreter(tmp_path / "py")
    assert (Path(exe).parent / "resources" / "emitter_boundary" / "EmitterBox.obj").is_file()
    out = subprocess.run([exe, "-c", "import dcdc, sys; print(sys.executable)"],
                         env={**os.environ, **extra}, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert Path(out.stdout.strip()).parent == Path(exe).parent


@pytest.mark.slow
@needs_splash
def test_runner_runs_an_emitter_scene_with_volume_maps(tmp_path, monkeypatch):
    """From another working directory, a relative path, an emitter (its housing mesh from
    SPlisHSPlasH's resources) and volume-map walls: it runs and reports per-fluid centroids."""
    scene = double_dam_break()
    scene["Configuration"]["stopAt"] = 0.05
    scene["RigidBodies"][0].update(scale=[0.6, 0.6, 0.6], translation=[0, 0.3, 0], mapResolution=[10, 10, 10])
    scene["FluidBlocks"] = [{"id": "first_fluid", "start": [-0.3, 0, -0.3], "end": [0, 0.2, 0]}]
    scene["Emitters"][0].update(translation=[0.1, 0.4, 0.0], width=2, height=2)
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "small.json").write_text(json.dumps(scene))
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "r.json"
    assert ss.main(["scenes/small.json", str(out), "--times", "0.02"]) == 0
    r = json.loads(out.read_text())
    assert r["status"] == "ok" and r["boundary_particles"] == 0
    assert "BoundaryModelBender2019" in r["boundary_models"]
    assert r["phases"]["first_fluid"]["particles"] == int(np.prod(block_counts([-0.3, 0, -0.3], [0, 0.2, 0], 0.025)))
    assert r["at"][0]["t"] == 0.02 and r["at"][0]["fluids"]["third_fluid"]["particles"] > 0


def test_benchmark_script_help():
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, str(root / "benchmarks" / "splishsplash_double_dam_break.py"),
                          "--duration", "0"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stderr.strip() == "error: --duration must be > 0 (got 0)"


def test_floor_row_height():
    """The mean height of the particles less than a radius above the lowest one."""
    assert ss.floor_row_height([0.2, 0.01, 0.03, 0.3], 0.025) == pytest.approx(0.02)
    assert ss.floor_row_height([], 0.025) is None
