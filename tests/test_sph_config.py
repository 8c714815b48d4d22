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
