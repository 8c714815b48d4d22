"""dcdc dataset export-lagrangebench: the files LagrangeBench (tumaer/lagrangebench 0.2.0)
reads. The format tests always run; the last test loads the export with LagrangeBench's own
H5Dataset and DataLoader collate and is skipped where ``lagrangebench`` is not installed."""
import json
import sys
import types
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from dcdc.data import lagrangebench as lb
from dcdc.data.dataset import Dataset
from dcdc.errors import DcdcError
from helpers import dcdc_output

ROOT = Path(__file__).resolve().parents[1]
TRAIN, TEST = ROOT / "data/sample/train2d", ROOT / "data/sample/test2d"


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    out = tmp_path_factory.mktemp("lb") / "2D_DCD_sample"
    meta = lb.export_lagrangebench({"train": TRAIN, "test": TEST}, out)
    return out, meta


def _force_fn(path):
    """``force_fn`` of a written force.py, with numpy standing in for jax.numpy."""
    fake = types.ModuleType("jax.numpy")
    fake.asarray = np.asarray
    jax = types.ModuleType("jax")
    jax.numpy = fake
    saved = {k: sys.modules.get(k) for k in ("jax", "jax.numpy")}
    sys.modules.update({"jax": jax, "jax.numpy": fake})
    try:
        scope = {}
        exec(compile(Path(path).read_text(), str(path), "exec"), scope)
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    return scope["force_fn"]


def test_layout_padding_types_and_positions(export):
    out, meta = export
    assert sorted(p.name for p in out.iterdir()) == ["force.py", "metadata.json", "test.h5", "train.h5"]
    assert json.loads((out / "metadata.json").read_text()) == meta
    nmax, origin = meta["num_particles_max"], np.array(meta["origin"])
    bounds, inner = np.array(meta["bounds"]), np.array(meta["particle_bounds"])
    cutoff = meta["default_connectivity_radius"]
    lattice, _ = lb.pad_lattice(inner[:, 1], cutoff, meta["padding"]["count_max"])
    counts = []
    for split, src in (("train", TRAIN), ("test", TEST)):
        trajs = list(Dataset(src))
        # LagrangeBench's generator: sequence_length = frames - 1 (the last frame is a target)
        assert meta[f"sequence_length_{split}"] == trajs[0].n_frames - 1 == 50
        assert meta[f"num_trajs_{split}"] == len(trajs)
        with h5py.File(out / f"{split}.h5") as f:
            assert list(f) == [f"{k:05d}" for k in range(len(trajs))]
            for key, t, row in zip(f, trajs, meta["trajectories"][split]):
                g = f[key]
                pos, pt = g["position"][()], g["particle_type"][()]
                n, m = t.n_particles, len(t.wall_x)
                counts.append(n + m)
                assert pos.shape == (51, nmax, 2) and pos.dtype == np.float32
                assert pt.shape == (nmax,) and pt.dtype == np.int32
                # fluid by phase, then walls, then padding (type -1) on the lattice
                np.testing.assert_array_equal(pt[:n], np.array(lb.PHASE_TYPES)[t.phase])
                assert set(pt[:n]) == set(np.array(lb.PHASE_TYPES)[:len(t.phases)])  # a type per phase
                assert (pt[n:n + m] == 1).all() and (pt[n + m:] == -1).all()
                np.testing.assert_allclose(pos[:, :n], t.position - origin, atol=2e-6)
                np.testing.assert_allclose(pos[:, n:n + m], np.broadcast_to(t.wall_x - origin, (51, m, 2)),
                                           atol=2e-6)
                pads = lattice[:nmax - n - m]
                np.testing.assert_allclose(pos[:, n + m:], np.broadcast_to(pads, (51,) + pads.shape), atol=1e-6)
                real = pos[:, :n + m].reshape(-1, 2)
                assert (real > t.radius * 0.99).all() and (real < inner[:, 1] - t.radius * 0.99).all()
                assert (pos >= 0).all() and (pos < bounds[:, 1]).all()
                # the phases' densities: per trajectory in metadata and in the group
                dens = [p.density for p in t.phases]
                assert row["phase_densities"] == dens and row["key"] == key
                np.testing.assert_allclose(g.attrs["phase_densities"], dens)
                np.testing.assert_allclose(g["density"][:n], t.density)
                assert (g["phase"][n:] == -1).all() and (g["density"][n:] == 0).all()
    assert max(counts) == nmax and min(counts) < nmax   # the sample needs padding
    assert bounds[:, 0].tolist() == [0.0, 0.0] and bounds[1, 1] == inner[1, 1] and bounds[0, 1] > inner[0, 1]
    assert meta["padding"]["count_max"] == nmax - min(counts)
    assert meta["particle_types"] == {"PAD_VALUE": -1, "FLUID": 0, "SOLID_WALL": 1, "FLUID_PHASE_1": 4}
    assert meta["t_end"] == pytest.approx(50 * 0.02) and meta["dt"] == 0.02 and meta["write_every"] == 1


def test_padding_lattice_makes_no_edges():
    """Padding particles stand a connectivity radius or more from every particle and from
    each other, inside the bounds, a few per neighbour-search cell."""
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(1)
    for extent, count in (([2.0, 1.5], 700), ([1.0, 0.8, 0.6], 900), ([0.3, 0.2], 40)):
        extent, cutoff = np.array(extent), 0.1125
        real = rng.uniform(0.025, extent - 0.025, (3000, len(extent)))
        pads, x_end = lb.pad_lattice(extent, cutoff, count)
        assert pads.shape == (count, len(extent)) and (pads[:, 0] < x_end).all()
        assert (pads[:, 1:] > 0).all() and (pads[:, 1:] < extent[1:]).all()
        assert cKDTree(real).query(pads)[0].min() > cutoff
        assert cKDTree(pads).query(pads, k=2)[0][:, 1].min() > cutoff
        box = np.r_[x_end, extent[1:]]
        cell = box / np.floor(box / cutoff)    # jax-md's cell size
        _, per_cell = np.unique(np.floor(pads / cell).astype(int), axis=0, return_counts=True)
        assert per_cell.max() <= 2 ** len(extent)


def test_statistics_and_collate(export):
    out, meta = export
    vel, acc, samples = [], [], []
    with h5py.File(out / "train.h5") as f:
        for key, row in zip(f, meta["trajectories"]["train"]):
            x = f[key]["position"][:, :row["num_fluid"]].astype(np.float64)
            v = np.diff(x, axis=0)
            vel.append(v.reshape(-1, 2))
            acc.append(np.diff(v, axis=0).reshape(-1, 2))
            # a LagrangeBench training sample: [particles, window, d] and the types
            samples.append((f[key]["position"][10:17].transpose(1, 0, 2), f[key]["particle_type"][()]))
    vel, acc = np.concatenate(vel), np.concatenate(acc)
    np.testing.assert_allclose(meta["vel_mean"], vel.mean(0), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(meta["vel_std"], vel.std(0), rtol=1e-9)
    np.testing.assert_allclose(meta["acc_mean"], acc.mean(0), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(meta["acc_std"], acc.std(0), rtol=1e-9)
    # trajectories of different particle counts stack (lagrangebench.data.utils.numpy_collate)
    pos = np.stack([s[0] for s in samples])
    assert pos.shape == (3, meta["num_particles_max"], 7, 2)
    assert np.stack([s[1] for s in samples]).shape == (3, meta["num_particles_max"])


def test_force_file_returns_the_gravity(export):
    out, meta = export
    force = _force_fn(out / "force.py")(np.zeros(2, np.float32))
    np.testing.assert_allclose(force, [0.0, -9.81], rtol=1e-6)
    assert force.dtype == np.float32 and meta["gravity"] == [0.0, -9.81]


def test_3d_export_and_no_force_without_gravity(tmp_path):
    from dcdc.render.benchmark import block_trajectory
    src = tmp_path / "src"
    src.mkdir()
    block_trajectory(src / "a.h5", 3, 60, frames=4, name="a", attrs={"gravity": np.zeros(3)})
    block_trajectory(src / "b.h5", 3, 40, frames=6, name="b", attrs={"gravity": np.zeros(3)})
    meta = lb.export_lagrangebench({"train": src}, tmp_path / "3D_DCD")
    assert sorted(p.name for p in (tmp_path / "3D_DCD").iterdir()) == ["metadata.json", "train.h5"]
    # cut to the shortest trajectory: 5 frames, sequence length 4
    assert meta["sequence_length_train"] == 4 and meta["dim"] == 3 and meta["gravity"] == [0.0, 0.0, 0.0]
    with h5py.File(tmp_path / "3D_DCD" / "train.h5") as f:
        shapes = {k: f[k]["position"].shape for k in f}
        types_b = f["00001"]["particle_type"][()]
    assert set(shapes.values()) == {(5, meta["num_particles_max"], 3)}
    b = Dataset(src)["b"]
    assert (types_b == -1).sum() == meta["num_particles_max"] - 40 - len(b.wall_x) > 0


def test_name_note_and_cli(tmp_path, capsys):
    code, out, err = dcdc_output(["dataset", "export-lagrangebench", "--train", TRAIN, "-o", tmp_path / "lb"],
                                 capsys)
    assert code == 0 and "+ force.py" in out
    meta = json.loads((tmp_path / "lb" / "metadata.json").read_text())
    name = f"2D_DCD_{meta['num_particles_max']}_50every1"
    assert err.startswith("note: ") and err.count("\n") == 1 and name in err
    assert lb.dataset_name(meta) == name and lb.NAME_PATTERN.search(name)
    code, out, err = dcdc_output(["dataset", "export-lagrangebench", "--train", TRAIN, "-o",
                                  tmp_path / name], capsys)
    assert code == 0 and err == ""


def test_refusals(tmp_path, monkeypatch):
    from dcdc.render.benchmark import block_trajectory
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    block_trajectory(a / "a.h5", 2, 30, frames=3, name="a")
    block_trajectory(b / "b.h5", 2, 30, frames=3, name="b", attrs={"gravity": np.array([0.0, -1.0])})
    with pytest.raises(DcdcError, match=r"b: gravity .* differs .* one gravity per dataset"):
        lb.export_lagrangebench({"train": a, "test": b}, tmp_path / "o1")
    with pytest.raises(DcdcError, match="needs a --train"):
        lb.export_lagrangebench({"test": a}, tmp_path / "o2")
    monkeypatch.setattr(lb, "PHASE_TYPES", (0,))
    with pytest.raises(DcdcError, match="2 phases; LagrangeBench has particle types for at most 1"):
        lb.export_lagrangebench({"train": a}, tmp_path / "o3")
    assert not any(tmp_path.glob("o*"))


def test_lagrangebench_loads_and_collates_a_batch_of_two(export):
    """LagrangeBench's own loader: H5Dataset (train windows and test trajectories), its
    force function, torch's DataLoader with its numpy_collate at batch size 2, and its
    case setup (matscipy neighbours, features, targets) on a sample of the batch."""
    pytest.importorskip("lagrangebench")
    from torch.utils.data import DataLoader

    from lagrangebench.data import H5Dataset
    from lagrangebench.data.utils import numpy_collate
    out, meta = export
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the directory name raises no naming warning
        train = H5Dataset("train", str(out), input_seq_length=6, extra_seq_length=2, nl_backend="matscipy")
    assert train.name == "dcd2d" and len(train) == 3 * (51 - 9 + 1)
    pos, ptype = next(iter(DataLoader(train, batch_size=2, shuffle=True, collate_fn=numpy_collate)))
    assert pos.shape == (2, meta["num_particles_max"], 9, 2) and ptype.shape == (2, meta["num_particles_max"])
    assert set(np.unique(ptype)) <= {-1, 0, 1, 4}
    np.testing.assert_allclose(np.asarray(train.external_force_fn(pos[0, 0, -1])), [0.0, -9.81], rtol=1e-6)
    import jax
    from lagrangebench import case_builder
    bounds = np.array(meta["bounds"])
    case = case_builder(box=bounds[:, 1] - bounds[:, 0], metadata=meta, input_seq_length=6,
                        cfg_neighbors={"backend": "matscipy", "multiplier": 2.0},
                        external_force_fn=train.external_force_fn, noise_std=0.0, dtype="float32")
    _, features, target, nbrs = case.allocate(jax.random.PRNGKey(0), (pos[0][:, :8], ptype[0]))
    real = int((ptype[0] != -1).sum())
    receivers, senders = np.asarray(nbrs.idx)
    # its neighbour search takes in the padding too: they get self-edges only (and unused
    # slots hold the fill index P)
    inner = (receivers < real) & (senders < real)
    assert real < meta["num_particles_max"] and np.all(inner | (receivers == senders))
    assert (inner & (receivers != senders)).sum() > real  # neighbours found
    force = np.asarray(features["force"])[:real]
    np.testing.assert_allclose(force, np.tile([0.0, -9.81], (real, 1)), rtol=1e-6)
    assert np.isfinite(np.asarray(target["acc"])[ptype[0] == 0]).all()
    test = H5Dataset("test", str(out), input_seq_length=6, extra_seq_length=20, nl_backend="matscipy")
    pos, ptype = next(iter(DataLoader(test, batch_size=2, collate_fn=numpy_collate)))
    assert pos.shape == (2, meta["num_particles_max"], 51, 2)   # 51 // 26 = 1 window: the whole run
