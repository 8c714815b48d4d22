"""dcdc benchmark table1: the paper's Table 1 rows are measured and consistent."""
import json

import pytest

from dcdc.evaluate.table1 import format_table, measure
from dcdc.model.networks import build_network
from helpers import dcdc_output


def test_a_row_measures_both_simulators_on_the_same_state():
    net = build_network("cconv", 2, channels=[4, 8, 8])
    row = measure("canyon", 2, net, seconds=0.06)
    nn, sph = row["neural"], row["sph"]
    assert row["fluid_particles"] > 100 and row["wall_particles"] > 100
    assert nn["steps"] == 3 and nn["dt"] == 0.02 and nn["ms_per_step"] > 0
    assert nn["s_per_simulated_s"] == pytest.approx(nn["ms_per_step"] / 1e3 / 0.02)
    assert sph["simulated_s"] == pytest.approx(0.06) and sph["substeps"] >= 3
    assert sph["mean_substep_s"] == pytest.approx(0.06 / sph["substeps"])
    assert row["speedup"] == pytest.approx(sph["s_per_simulated_s"] / nn["s_per_simulated_s"])
    assert row["paper_s_per_step"] == {"ours": 0.0099, "imm_mixture": 0.0112}
    assert nn["contact"] is True  # a network without a serving default keeps the contact
    assert "| canyon 2-D (cconv, contact) |" in format_table([row])


def test_bad_arguments_are_one_line(tmp_path, capsys):
    code, _, err = dcdc_output(["benchmark", "table1", "--seconds", "0"], capsys)
    assert code == 2 and err.strip() == "error: --seconds and --seconds3d must be > 0"
    code, _, err = dcdc_output(["benchmark", "table1", "--model", "dcdc2d", "--model3d",
                                "dcdc2d", "--json", str(tmp_path / "t.json")], capsys)
    assert code == 2 and "is a 2-D model, expected 3-D" in err and err.count("\n") == 1
    assert not (tmp_path / "t.json").exists()


def test_the_shipped_2d_network_is_timed_as_it_is_served():
    """dcdc2d runs alone by default, so Table 1 times it without the wall contact."""
    from dcdc.model.checkpoint import load_checkpoint

    row = measure("canyon", 2, load_checkpoint("dcdc2d")[0], seconds=0.04)
    assert row["neural"]["contact"] is False and row["neural"]["contacts"] == 0
    assert "| canyon 2-D (dcdc, alone) |" in format_table([row])
