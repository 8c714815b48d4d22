"""benchmarks/make_deep_columns.py writes valid scenes of the kind it documents."""
import subprocess
import sys

import pytest
from pathlib import Path

import numpy as np

from dcdc.scene import get_scene

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "make_deep_columns.py"


def _run(args):
    """The script as a user runs it (tests import nothing from benchmarks/)."""
    subprocess.run([sys.executable, str(SCRIPT), *args], check=True)


def test_deep_column_scenes_are_deep_layered_and_in_the_training_range(tmp_path):
    _run([str(tmp_path), "4", "0"])
    files = sorted(tmp_path.glob("*.toml"))
    assert len(files) == 4
    for f in files:
        sc = get_scene(str(f))
        sy = sc.realize(dim=3)
        y = sy.x[:, 1]
        assert 0.75 <= y.max() - y.min() + 2 * sy.radius <= 1.55  # a column 0.8-1.5 m deep
        rho = np.array([p.density for p in sy.phases])
        assert 2 <= len(rho) <= 4 and rho.max() / rho.min() <= 10
        assert all((sy.phase == k).sum() > 0 for k in range(len(rho)))  # no empty layer
        assert y.min() < 0.05  # resting on the floor from its lattice start
        # no empty row: the layers and the tank's walls tile the lattice (a gap makes the
        # column start by falling into it, a transient the SPH data would teach)
        levels = np.unique(y.round(6))
        np.testing.assert_allclose(np.diff(levels), 2 * sy.radius, atol=1e-6)
        lo, hi = sy.x.min(0), sy.x.max(0)
        box = np.array([float(v) for v in f.read_text().split("max = [")[1].split("]")[0].split(",")])
        for a in (0, 2):
            assert lo[a] == np.float32(sy.radius) or abs(lo[a] - sy.radius) < 1e-6
            assert abs(box[a] - hi[a] - sy.radius) < 1e-6
        assert len(y) == len(levels) * round(box[0] / (2 * sy.radius)) * round(box[2] / (2 * sy.radius))


@pytest.mark.slow
def test_deep_glass_scenes_hold_layered_columns_in_a_glass(tmp_path):
    _run([str(tmp_path), "12", "0", "glass"])  # seed 11 once left a layer empty
    files = sorted(tmp_path.glob("deep_glass_*.toml"))
    assert len(files) == 12
    for f in files:
        sy = get_scene(str(f)).realize(dim=3)
        y = sy.x[:, 1]
        assert 0.4 <= y.max() - y.min() <= 1.3  # 60-90 % of a 0.8-1.8 m glass
        rho = np.array([p.density for p in sy.phases])
        assert 2 <= len(rho) <= 4 and rho.max() / rho.min() <= 10
        assert all((sy.phase == k).sum() > 0 for k in range(len(rho)))
        assert len(np.unique(sy.x.round(6), axis=0)) == len(sy.x)  # stacked fills: no doubles
        r_xz = np.linalg.norm(sy.x[:, [0, 2]], axis=1)
        assert r_xz.max() < 0.7  # inside the glass's rim radius


def test_neck_scenes_put_heavy_liquid_over_light_across_a_slotted_plate(tmp_path):
    _run([str(tmp_path), "8", "0", "neck"])
    files = sorted(tmp_path.glob("deep_neck_*.toml"))
    assert len(files) == 8
    for f in files:
        for dim in (2, 3):
            sy = get_scene(str(f)).realize(dim=dim)
            rho = np.array([p.density for p in sy.phases])
            assert len(rho) == 2 and 1.5 <= rho[1] / rho[0] <= 10.05 and rho.max() <= 5000
            y = sy.x[:, 1]
            light, heavy = y[sy.phase == 0], y[sy.phase == 1]
            assert heavy.min() > light.max()  # an inversion: all the heavy liquid on top
            # one slot: the light particles level with the plate fill one contiguous run,
            # 2-6 spacings (0.1-0.3 m) wide, between the plate's two parts
            y_top = light.max()
            in_slot = np.isclose(y, y_top, atol=1e-6) & (sy.phase == 0)
            xs = np.sort(sy.x[in_slot, 0])
            assert 2 <= len(np.unique(xs.round(6))) <= 6
            np.testing.assert_allclose(np.diff(np.unique(xs.round(6))), 2 * sy.radius, atol=1e-6)
            # the chamber below is full: every lattice row up to the plate is occupied
            levels = np.unique(y.round(6))
            np.testing.assert_allclose(np.diff(levels), 2 * sy.radius, atol=1e-6)


def test_lock_scenes_hold_two_full_depth_columns_unlike_the_builtin(tmp_path):
    _run([str(tmp_path), "30", "0", "lock"])
    files = sorted(tmp_path.glob("deep_lock_*.toml"))
    assert len(files) == 30
    for f in files:
        sy = get_scene(str(f)).realize(dim=2)
        rho = np.array([p.density for p in sy.phases])
        ratio = rho.max() / rho.min()
        assert len(rho) == 2 and 1.05 <= ratio <= 10.05
        length = sy.x[:, 0].max() + sy.radius  # the tank starts at x = 0
        assert not (length >= 1.7 - 1e-6 and 1.3 <= ratio <= 1.7)  # not the built-in's
        # side by side over the same depth: one phase left of a vertical gate, one right
        x0, x1 = sy.x[sy.phase == 0, 0], sy.x[sy.phase == 1, 0]
        assert x0.max() < x1.min() or x1.max() < x0.min()
        y0, y1 = sy.x[sy.phase == 0, 1], sy.x[sy.phase == 1, 1]
        assert abs(y0.max() - y1.max()) < 1e-6 and abs(y0.min() - y1.min()) < 1e-6


def test_unknown_kind_is_refused(tmp_path):
    import subprocess
    import sys
    r = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path), "1", "0", "cup"],
                       capture_output=True, text=True)
    assert r.returncode == 1 and r.stderr.strip().startswith("error: KIND must be one of")
