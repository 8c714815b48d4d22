"""SPHConfig: dict round trip and one-line errors naming the bad key or value."""
import pytest

from dcdc.errors import DcdcError
from dcdc.sph import SPHConfig


def test_round_trip():
    cfg = SPHConfig(solver="wcsph", cfl=0.3, viscosity=0.0)
    assert SPHConfig.from_dict(cfg.to_dict()) == cfg
    assert SPHConfig.from_dict({"dt_max": 1}).dt_max == 1.0  # int accepted for a float
    assert SPHConfig.from_dict({"background_pressure": 250}).background_pressure == 250.0


@pytest.mark.parametrize("d, word", [
    ({"solvr": "dfsph"}, "solvr"),
    ({"solver": "sph2000"}, "solver"),
    ({"cfl": -1.0}, "cfl"),
    ({"cfl": "fast"}, "cfl"),
    ({"max_iterations": 0}, "max_iterations"),
    ({"viscosity": float("nan")}, "viscosity"),
    ({"divergence_solve": "yes"}, "divergence_solve"),
    ({"dt_min": 1.0, "dt_max": 0.001}, "dt_min"),
    ({"background_pressure": -1.0}, "background_pressure"),
])
def test_bad_settings_name_the_problem(d, word):
    with pytest.raises(DcdcError, match=word) as e:
        SPHConfig.from_dict(d)
    assert "\n" not in str(e.value)


def test_not_a_dict():
    with pytest.raises(DcdcError):
        SPHConfig.from_dict([1, 2])


# ---------------------------------------------------------------- each option has an effect
def _tank(v=(0.0, 0.0), light_left: bool = False):
    """A 0.3 × 0.15 m tank of water at rest on the lattice (r = 2.5 cm, 18 particles);
    ``v`` its start velocity; ``light_left``: the left column a 500 kg/m³ phase."""
    import numpy as np

    from dcdc.particles import Phase
    from dcdc.sph.fixtures import tank_system

    phase_of = (lambda p: np.where(p[:, 0] < 0.05, 1, 0)) if light_left else \
        (lambda p: np.zeros(len(p), int))
    sy = tank_system(2, 0.025, [0.3, 0.15], [(np.zeros(3), [0.3, 0.15, 0], phase_of)],
                     [Phase("water", 1000.0), Phase("light", 500.0)], wall_height=0.4)
    sy.v[:] = v
    return sy


def _frame(cfg: dict, frames: int = 1, **tank):
    from dcdc.sph import Simulator

    sim = Simulator(_tank(**tank), SPHConfig.from_dict(cfg))
    for _ in range(frames):
        stats = sim.advance(0.02)
    return sim, stats


def test_substep_follows_cfl_speed_floor_and_dt_max():
    """Δt = min(dt_max, cfl·2r / max(|v|, speed_floor)) (docs/sph.md, "Substeps"): at
    rest with r = 2.5 cm the defaults give 5 ms, four substeps per 20 ms frame."""
    from dcdc.sph.solver import rest_substep

    assert _frame({})[1]["substeps"] == 4 and rest_substep(SPHConfig(), _tank()) == 0.005
    assert _frame({"speed_floor": 8.0})[1]["substeps"] == 8
    assert _frame({"cfl": 0.2})[1]["substeps"] == 8
    assert _frame({"dt_max": 0.002})[1]["substeps"] == 10


def test_dt_min_stops_the_run():
    from dcdc.errors import SimulationDiverged

    with pytest.raises(SimulationDiverged, match="dt_min"):
        _frame({"speed_floor": 8.0, "dt_min": 0.004})


def test_pressure_solver_iterations():
    """max_iterations caps the conjugate-gradient iterations, min_iterations adds Jacobi
    sweeps (relaxed by omega) after them, divergence_solve switches the first solve off,
    and a tighter density_tolerance takes more iterations."""
    import numpy as np

    base = _frame({}, frames=3, v=(0.0, -1.0))
    assert base[1]["divergence_iterations"] > 0
    assert _frame({"divergence_solve": False})[1]["divergence_iterations"] == 0
    capped = _frame({"max_iterations": 1, "min_iterations": 1}, frames=3, v=(0.0, -1.0))[1]
    assert capped["iterations"] == 2 and capped["divergence_iterations"] == 2
    assert _frame({"max_iterations": 3, "min_iterations": 3}, v=(0.0, -1.0))[1]["iterations"] >= 4
    tight = _frame({"density_tolerance": 1e-8}, frames=3, v=(0.0, -1.0))[1]
    assert tight["iterations"] > base[1]["iterations"]
    relaxed = _frame({"omega": 1.0}, frames=3, v=(0.0, -1.0))[0]
    assert not np.array_equal(relaxed.system.x, base[0].system.x)


def test_no_slip_walls_hold_back_a_sliding_layer():
    """no_slip: the Morris viscosity against the wall particles slows fluid sliding along
    the floor; free slip (the default) exerts no tangential force."""
    import numpy as np

    slip = _frame({"viscosity": 0.01}, frames=2, v=(0.5, 0.0))[0].system
    grip = _frame({"viscosity": 0.01, "no_slip": True}, frames=2, v=(0.5, 0.0))[0].system
    floor = slip.x[:, 1] < 0.05
    assert np.mean(grip.v[floor, 0]) < np.mean(slip.v[floor, 0])


def test_wall_buoyancy_acts_through_the_volume_map_only():
    import numpy as np

    def x(cfg):
        return _frame(cfg, frames=2, light_left=True)[0].system.x

    assert not np.array_equal(x({"wall_buoyancy": True}), x({}))
    particles = {"boundary": "particles"}
    assert np.array_equal(x({**particles, "wall_buoyancy": True}), x(particles))


def test_wcsph_sound_speed_and_stiffness_exponent():
    """WCSPH: Δt <= cfl·2r / (c_max + |v|) with c the given sound_speed (0: 10 sqrt(2 g H)),
    and p = B max(ψ^γ - 1, 0) with γ the stiffness_exponent."""
    import numpy as np

    wc = {"solver": "wcsph"}
    auto, _ = _frame(wc)
    assert auto._sound_speed == pytest.approx(10 * np.sqrt(2 * 9.81 * 0.15))
    c30 = _frame({**wc, "sound_speed": 30.0})
    c60 = _frame({**wc, "sound_speed": 60.0})
    assert c30[0]._sound_speed == 30.0
    assert c60[1]["substeps"] > 1.9 * c30[1]["substeps"]
    soft = _frame({**wc, "sound_speed": 30.0, "stiffness_exponent": 1.0})[0]
    assert not np.allclose(soft.pressure(), c30[0].pressure())
