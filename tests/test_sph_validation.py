"""Quick variants of `dcdc validate-sph` (the full ones are run for the README)."""
import json
import subprocess
import sys

import pytest

from dcdc.sph import SPHConfig
from dcdc.sph.cases import CASES


@pytest.mark.slow
@pytest.mark.parametrize("name", ["dam_break", "side_by_side", "rayleigh_taylor", "four_phase"])
def test_quick_case_2d(name):
    rows = CASES[name](2, True, SPHConfig())
    assert all(r.passed for r in rows), [(r.quantity, r.measured, r.reference) for r in rows]


@pytest.mark.slow
def test_quick_side_by_side_3d():
    rows = CASES["side_by_side"](3, True, SPHConfig())
    assert all(r.passed for r in rows), [(r.quantity, r.measured, r.reference) for r in rows]


def test_cli_table_and_json(tmp_path):
    out = tmp_path / "v.json"
    r = subprocess.run([sys.executable, "-m", "dcdc.cli", "validate-sph", "--quick", "--case",
                        "hydrostatic", "--json", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "measured" in r.stdout and "PASS" in r.stdout
    doc = json.loads(out.read_text())
    assert doc["passed"] and doc["quick"] and len(doc["rows"]) == 4


def test_energy_budget_catches_created_energy():
    """The energy check of the closed tanks: an honest run stays below the released
    potential energy; the same run with its velocities doubled once does not."""
    import numpy as np

    from dcdc.particles import Phase
    from dcdc.sph import Simulator
    from dcdc.sph.cases import EnergyBudget, _closed_tank
    phases = [Phase("heavy", 1000.0), Phase("light", 100.0)]
    sy, _ = _closed_tank(2, True, 0.8, 0.4, phases, lambda p: np.where(p[:, 0] < 0.4, 0, 1), "t")
    sim = Simulator(sy, SPHConfig())
    honest = EnergyBudget(sim)
    for f in range(15):
        sim.advance(0.02)
        honest(sim, f)
    assert honest.excess() < 0.0 and honest.row("t").passed
    pumped = EnergyBudget(sim)
    pumped.pe0 = honest.pe0  # the same start
    sy.v *= 2.0
    pumped(sim, 15)
    assert pumped.excess() > 0.01 and not pumped.row("t").passed
