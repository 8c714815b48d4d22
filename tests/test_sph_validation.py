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
