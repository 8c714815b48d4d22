"""The Python API (docs/api.md): the documented example runs as written, and the package
entry points a notebook user looks for exist."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _example() -> str:
    text = (ROOT / "docs" / "api.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "docs/api.md has no python example"
    return blocks[0]


def test_import_is_lazy_and_exposes_the_api():
    code = ("import sys, dcdc; "
            "assert 'torch' not in sys.modules and 'numba' not in sys.modules, 'eager import'; "
            "names = ['load_scene', 'load_model', 'simulate', 'rollout', 'run_sph', 'Run']; "
            "assert all(callable(getattr(dcdc, n)) for n in names); "
            "assert callable(dcdc.sph.run)")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_sph_run_keeps_every_frame_of_a_system():
    """``dcdc.sph.run`` in a fresh interpreter: a realised system advanced frame by frame, the
    API layer (``dcdc.api``) left unimported; ``dcdc.run_sph`` gives the same frames."""
    code = ("import sys, numpy as np, dcdc.sph; from dcdc.scene import get_scene; "
            "system = get_scene('dam_break').realize(dim=2, resolution=0.5); "
            "x0 = system.x.copy(); "
            "pos, vel, t = dcdc.sph.run(system, dcdc.sph.SPHConfig(), frames=2, frame_dt=0.02); "
            "assert 'dcdc.api' not in sys.modules, 'sph imports the API'; "
            "assert pos.shape == (3,) + x0.shape and vel.shape == pos.shape; "
            "assert pos.dtype == np.float32 and np.allclose(t, [0.0, 0.02, 0.04]); "
            "assert np.array_equal(pos[0], x0.astype(np.float32)); "
            "assert np.array_equal(pos[-1], system.x.astype(np.float32)); "
            "import dcdc; r = dcdc.run_sph('dam_break', dim=2, resolution=0.5, duration=0.04); "
            "assert np.array_equal(r.position, pos) and np.allclose(r.time, t)")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)


def test_python_m_dcdc():
    r = subprocess.run([sys.executable, "-m", "dcdc", "--help"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "demo" in r.stdout and "simulate" in r.stdout


def test_load_scene_errors_are_one_line():
    import dcdc
    from dcdc.errors import DcdcError
    with pytest.raises(DcdcError, match="density"):
        dcdc.load_scene('name = "x"\ndim = 2\n[phases.a]\ndensity = -1\n')
    with pytest.raises(DcdcError):
        dcdc.load_scene("no_such_scene")


@pytest.mark.slow
def test_docs_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(_example(), "docs/api.md", "exec"), ns)
    truth, pred = ns["truth"], ns["pred"]
    n = truth.position.shape[1]
    assert truth.position.shape == (11, n, 2) and pred.position.shape == (11, n, 2)
    assert truth.velocity.shape == truth.position.shape
    assert np.allclose(truth.time, 0.02 * np.arange(11)) and np.allclose(pred.time, truth.time)
    for run in (truth, pred):
        assert np.isfinite(run.position).all() and np.isfinite(run.velocity).all()
        h = run.heights()
        assert list(h) == ["light", "heavy"] and all(np.isfinite(v) for v in h.values())
        # side by side at the start, the heavy half slumps under the light one within 0.2 s
        assert h["heavy"] < h["light"], (run.solver, h)
    assert pred.stopped is None and np.isfinite(pred.ms_per_step)
    assert np.array_equal(truth.position[0], pred.position[0])  # the same lattice start
    assert truth.solver.startswith("dcdc.sph") and pred.solver.startswith("dcdc.neural")
    from dcdc.data.dataset import Dataset
    saved = Dataset(tmp_path / "two_layers_dcdc2d.h5")["two_layers_2d"]
    assert np.allclose(saved.position, pred.position)
    assert "(11, " in capsys.readouterr().out


def test_rollout_from_a_system():
    import dcdc
    system = dcdc.load_scene("dam_break").realize(dim=2, resolution=0.5)
    run = dcdc.rollout("dcdc2d", system, 3)
    assert run.position.shape[0] == 4 and run.n_frames == 4
    assert run.stopped is None and np.isfinite(run.position).all()
