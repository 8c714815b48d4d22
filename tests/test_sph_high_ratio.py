"""High density ratios (15:1, 20:1): the validation rows of `validate-sph --case high_ratio`,
and `dcdc generate` refusing trajectories whose particles sit on top of each other."""
import json

import numpy as np
import pytest

from dcdc.data import generate as gen
from dcdc.data.dataset import write_trajectory
from dcdc.particles import Phase
from dcdc.sph import SPHConfig
from dcdc.sph import measures
from dcdc.sph.cases import CASES
from dcdc.sph.fixtures import one_phase, tank_system

R = 0.025


def test_first_coincident_finds_the_first_close_pair():
    x = np.zeros((3, 4, 2))
    x[:, :, 0] = [0.0, 2 * R, 4 * R, 6 * R]
    x[2, 3] = [4 * R + 0.02 * R, 0.0]  # frame 2: particles 2 and 3 are 0.02 r apart
    assert gen.first_coincident(x[:2], R, frames=1, particles=1) is None
    k, i, j, d = gen.first_coincident(x, R, frames=1, particles=1)
    assert (k, i, j) == (2, 2, 3) and d == pytest.approx(0.02 * R)


def test_coincident_means_staying_together_not_passing():
    """Particles that pass within 0.05 r for a few frames and part, or a lone jammed pair,
    are not a collapse; three stuck for COINCIDENT_FRAMES frames are, reported at the
    start of the first one's streak."""
    T, K = 40, gen.COINCIDENT_FRAMES
    x = np.zeros((T, 5, 2))
    x[:, :, 0] = [0.0, 2 * R, 4 * R, 6 * R, 8 * R]
    x[5:5 + K - 1, 3] = [4 * R + 0.02 * R, 0.0]  # close for K - 1 frames, then apart
    x[:, 4] = [6 * R + 0.01 * R, 0.0]  # particle 4 jammed against 3 for the whole run
    assert gen.first_coincident(x, R) is None
    x[20:, 1] = [0.01 * R, 0.0]  # from frame 20 on particle 1 sits on particle 0
    k, i, j, d = gen.first_coincident(x, R)
    assert k == 20 or (k, i, j) == (0, 3, 4)
    assert gen.first_coincident(x, R, particles=5) is None


def test_first_coincident_compares_active_particles_only():
    """An unborn particle waits at its nozzle and a removed one stays where it left: neither
    is compared (dcdc.particles.active_mask)."""
    x = np.zeros((2, 3, 2))
    x[:, :, 0] = [0.0, 2 * R, 0.01 * R]  # particle 2 on top of particle 0
    times = np.array([0.0, 0.02])
    birth = np.array([0.0, 0.0, 0.02])
    hit = gen.first_coincident(x, R, times, birth, np.full(3, np.inf), frames=1, particles=1)
    assert hit[:3] == (1, 0, 2)  # born in frame 1
    death = np.array([np.inf, np.inf, 0.0])
    assert gen.first_coincident(x, R, times, np.zeros(3), death, frames=1, particles=1) is None


def _trajectory(tmp_path, name, close: bool):
    sy = tank_system(2, R, [0.2, 0.1], [(np.zeros(3), [0.2, 0.1, 0.0], one_phase(0))],
                     [Phase("w", 1000.0)])
    T = 4 + gen.COINCIDENT_FRAMES
    xs = np.repeat(sy.x[None], T, axis=0).astype(np.float32)
    if close:  # from frame 3 on, particle 1 sits 0.1 r from particle 0
        xs[3:, 1] = xs[3:, 0] + [0.01 * R, 0.0]
        xs[3:, 2] = xs[3:, 0] + [0.0, 0.01 * R]
    write_trajectory(tmp_path / f"{name}.h5", name, xs, np.zeros_like(xs), 0.02 * np.arange(T),
                     sy, {"name": name})
    return {"name": name, "status": "ok", "source": "test", "dim": 2, "seed": 0}


def test_generate_refuses_a_trajectory_with_coincident_particles(tmp_path):
    """The file goes, NAME.failed.json stays with a one-line reason; a clean one is kept."""
    ok = gen.check_written(tmp_path, _trajectory(tmp_path, "clean", close=False))
    assert ok["status"] == "ok" and (tmp_path / "clean.h5").exists()
    rec = gen.check_written(tmp_path, _trajectory(tmp_path, "bad", close=True))
    assert rec["status"] == "failed" and not (tmp_path / "bad.h5").exists()
    assert "coincident particles" in rec["error"] and "frame 3" in rec["error"]
    assert "\n" not in rec["error"]
    stored = json.loads((tmp_path / "bad.failed.json").read_text())
    assert stored["error"] == rec["error"]


def test_the_generate_limit_is_inside_the_validation_limit():
    """The validation rows ask more (no pair within 0.3 r in any frame) than generate
    refuses (a collapse: particles stuck within 0.05 r)."""
    assert gen.COINCIDENT < measures.COINCIDENT == 0.3


def _rows(dim):
    rows = CASES["high_ratio"](dim, True, SPHConfig())
    by = {}
    for r in rows:
        by.setdefault(r.case.split(" ")[0], {})[r.quantity.split(" (")[0]] = r
    assert set(by) == {"15:1", "20:1"}
    return by


def _check(by):
    """Layers (heavy below, purity) and volumes must pass; the closest pair is reported."""
    for ratio, rows in by.items():
        for q in ("heavy below light", "layer purity", "volume change heavy",
                  "volume change light"):
            assert rows[q].passed, (ratio, q, rows[q].measured)
    closest = {k: v["closest pair over all frames [r]"].measured for k, v in by.items()}
    if min(closest.values()) < measures.COINCIDENT:
        pytest.xfail(f"closest pair {closest} r: particles still meet where the pressure is "
                     "zero (docs/sph.md, 'High density ratios')")


def test_high_ratio_layers_2d():
    _check(_rows(2))


@pytest.mark.slow
def test_high_ratio_layers_3d():
    _check(_rows(3))
