"""Bad input gives a one-line DcdcError (CLI: `error: ...`, exit 2), never a traceback."""
import subprocess
import sys

import numpy as np
import pytest

from dcdc.errors import DcdcError, SimulationDiverged
from dcdc.particles import ParticleSystem, Phase
from dcdc.sph import SPHConfig, Simulator
from dcdc.sph.fixtures import tank_system


def small_tank(dim=2):
    size = [0.3, 0.2, 0.2][:dim]
    return tank_system(dim, 0.025, size, [(np.zeros(3), size + [0] * (3 - dim),
                                           lambda p: np.zeros(len(p), int))],
                       [Phase("water", 1000.0)], wall_height=0.4)


def one_line(exc):
    msg = str(exc.value)
    assert msg and "\n" not in msg
    return msg


def test_unknown_solver():
    with pytest.raises(DcdcError, match="solver") as e:
        Simulator(small_tank(), SPHConfig(solver="sph2000"))
    one_line(e)


def test_density_not_positive():
    with pytest.raises(DcdcError, match="density") as e:
        Phase("oil", 0.0)
    one_line(e)
    sy = small_tank()
    object.__setattr__(sy.phases[0], "density", -5.0)  # bypassing Phase's own check
    with pytest.raises(DcdcError, match="density"):
        Simulator(sy)


def test_fluid_inside_a_wall():
    sy = small_tank()
    sy.x[0] = sy.wall_x[len(sy.wall_x) // 2] + 0.001
    with pytest.raises(DcdcError, match="inside a wall") as e:
        Simulator(sy)
    one_line(e)


def test_fluid_behind_a_wall_surface():
    sy = small_tank()
    sy.x[0] = [-0.06, 0.1]  # inside the left wall's shell, between its layers
    with pytest.raises(DcdcError, match="inside a wall"):
        Simulator(sy)


def test_particle_outside_domain():
    sy = small_tank()
    sy.x[3] = [0.1, 50.0]
    with pytest.raises(DcdcError, match="outside the domain") as e:
        Simulator(sy)
    one_line(e)


def test_nan_input_and_state():
    sy = small_tank()
    sy.v[2, 0] = np.nan
    with pytest.raises(DcdcError, match="NaN"):
        Simulator(sy)
    sy = small_tank()
    sim = Simulator(sy)
    sy.v[2, 0] = np.nan  # a state that turns NaN during the run
    with pytest.raises(SimulationDiverged, match="NaN") as e:
        sim.advance(0.02)
    one_line(e)


def test_explosion_is_reported():
    sy = small_tank()
    sim = Simulator(sy, SPHConfig(max_speed=20.0))
    sy.v[0] = [0.0, 500.0]
    with pytest.raises(SimulationDiverged) as e:
        sim.advance(0.02)
    one_line(e)


def test_bad_frame_dt_and_types():
    sim = Simulator(small_tank())
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(DcdcError, match="frame dt"):
            sim.advance(bad)
    with pytest.raises(DcdcError):
        Simulator("not a system")
    with pytest.raises(DcdcError):
        Simulator(small_tank(), {"solver": "dfsph"})


def test_empty_scene():
    sy = ParticleSystem(2, 0.025, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0),
                        [Phase("w", 1000.0)], np.zeros((0, 2)), np.zeros((0, 2)), [0, -9.81],
                        ([0, 0], [1, 1]))
    with pytest.raises(DcdcError, match="no fluid"):
        Simulator(sy)


def cli(*args):
    return subprocess.run([sys.executable, "-m", "dcdc.cli", *args], capture_output=True, text=True)


@pytest.mark.slow
def test_cli_bad_options_are_one_line_errors():
    r = cli("benchmark", "sph", "--ratios", "ten")
    assert r.returncode == 2
    assert r.stderr.strip().startswith("error:") and "Traceback" not in r.stderr
    r = cli("validate-sph", "--dim", "4")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    for bad in ("nosuchkey=1", "xsph=-1", "xsph"):
        r = cli("validate-sph", "--quick", "--case", "hydrostatic", "--sph", bad)
        assert r.returncode != 0 and "Traceback" not in r.stderr, bad
        assert len(r.stderr.strip().splitlines()) == 1 and "sph" in r.stderr, (bad, r.stderr)


@pytest.mark.slow
def test_benchmark_sph_small_run_writes_median_of_repeats(tmp_path):
    out = tmp_path / "b.json"
    r = cli("benchmark", "sph", "--dim", "2", "--particles", "200", "--duration", "0.04",
            "--ratios", "10", "--repeat", "3", "--no-splishsplash", "--json", str(out))
    assert r.returncode == 0, r.stderr
    import json
    doc = json.loads(out.read_text())
    (res,) = doc["results"]
    samples = res["wall_s_per_simulated_s_samples"]
    assert len(samples) == 3 and res["wall_s_per_simulated_s"] == sorted(samples)[1]
    assert res["stable"] and res["fluid_particles"] > 100 and res["ratio"] == "10:1"
    assert doc["repeat"] == 3 and len(doc["machine"]["load_average_1min"]) == 2
    r = cli("benchmark", "sph", "--repeat", "0")
    assert r.returncode == 2 and r.stderr.startswith("error:")
