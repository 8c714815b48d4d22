"""Dataset integrity and the per-trajectory density-ratio metadata."""
from pathlib import Path

import h5py
import numpy as np
import pytest

from dcdc.data import Dataset, merge
from dcdc.data.dataset import max_density_ratio, verify
from dcdc.data.generate import generate, random_jobs, scene_jobs
from dcdc.errors import DcdcError
from dcdc.scene.random import RandomSceneConfig
from helpers import format1_copy

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def ds(tmp_path_factory):
    out = tmp_path_factory.mktemp("integrity") / "ds"
    generate(random_jobs(2, 0, RandomSceneConfig(dim=2, max_ratio=4.0), duration=0.1), out,
             simulator="ballistic", progress=False)
    return out


def test_every_array_carries_a_checksum(ds):
    with h5py.File(ds / "random_0_2d.h5") as f:
        g = f["random_0_2d"]
        assert f.attrs["format_version"] == 2 and "attrs_sha256" in g.attrs
        assert all(g[k].fletcher32 for k in g if g[k].size)
    assert verify(Dataset(ds)) == {"verified": ["random_0_2d", "random_1_2d"], "unverifiable": [],
                                   "corrupt": {}}


def test_sample_in_git_is_verifiable():
    for sub in ("train2d", "test2d"):
        sample = Dataset(ROOT / "data/sample" / sub)
        assert verify(sample) == {"verified": sample.names, "unverifiable": [], "corrupt": {}}


def test_old_files_stay_readable_but_unverifiable(tmp_path):
    for p in (ROOT / "data/sample/train2d").glob("*.h5"):
        format1_copy(p, tmp_path / p.name)
    old = Dataset(tmp_path)
    t = old[0]
    assert t.position.shape[0] == t.n_frames and np.isfinite(t.position).all()
    assert "max_density_ratio" not in t.attrs  # format 1: computed on the fly
    assert t.max_density_ratio == pytest.approx(t.density.max() / t.density.min())
    assert verify(old)["unverifiable"] == old.names


def test_merge_keeps_checksums(ds, tmp_path):
    merge([ds], tmp_path / "m.h5")
    m = Dataset(tmp_path / "m.h5")
    assert verify(m)["verified"] == m.names
    assert np.array_equal(m["random_1_2d"].position, Dataset(ds)["random_1_2d"].position)


def test_max_density_ratio_stored(ds):
    for t in Dataset(ds):
        assert t.attrs["max_density_ratio"] == pytest.approx(t.density.max() / t.density.min())
        assert t.max_density_ratio == t.attrs["max_density_ratio"] >= 1


def test_max_density_ratio_counts_only_born_particles():
    rho = np.array([1000.0, 1000.0, 5000.0])
    assert max_density_ratio(rho, np.array([0.0, 0.0, 3.0]), t_end=2.0) == 1.0
    assert max_density_ratio(rho, np.array([0.0, 0.0, 3.0]), t_end=3.0) == 5.0


def test_emitter_scene_ratio(tmp_path):
    """examples/my_scene.toml pours syrup (1800) into oil (800) over water (1000)."""
    jobs = scene_jobs([ROOT / "examples/my_scene.toml"], dim=2, duration=0.1)
    generate(jobs, tmp_path, simulator="ballistic", progress=False)
    t = Dataset(tmp_path)[0]
    born = t.birth <= t.time[-1] + 1e-9
    assert t.max_density_ratio == pytest.approx(t.density[born].max() / t.density[born].min())


def test_trajectory_read_fails_loudly_on_flipped_bits(ds, tmp_path):
    p = tmp_path / "x.h5"
    p.write_bytes((ds / "random_0_2d.h5").read_bytes())
    with h5py.File(p) as f:
        off = f["random_0_2d/velocity"].id.get_chunk_info(2).byte_offset
    b = bytearray(p.read_bytes())
    b[off + 9] ^= 0x10
    p.write_bytes(bytes(b))
    t = Dataset(p)["random_0_2d"]
    assert t.position.shape[0] == 6  # the undamaged array reads
    with pytest.raises(DcdcError, match="velocity"):
        t.velocity
