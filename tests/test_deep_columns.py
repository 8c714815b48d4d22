"""benchmarks/make_deep_columns.py writes valid scenes of the kind it documents."""
import importlib.util
from pathlib import Path

import numpy as np

from dcdc.scene import get_scene

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "make_deep_columns.py"


def _module():
    spec = importlib.util.spec_from_file_location("make_deep_columns", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_deep_column_scenes_are_deep_layered_and_in_the_training_range(tmp_path):
    _module().main([str(tmp_path), "4", "0"])
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
