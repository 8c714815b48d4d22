"""Export to the LagrangeBench layout (tumaer/lagrangebench): a directory with
``train.h5`` / ``valid.h5`` / ``test.h5`` (groups ``00000``, ``00001``, ... each holding
``position`` [T, N, d] and ``particle_type`` [N]) and ``metadata.json``.

Walls become static particles of type 1 (SOLID_WALL), fluid is type 0 (FLUID). Our extra
per-particle arrays ``phase`` (-1 for walls) and ``density`` (rest density, 0 for walls) are
written beside them so multiphase information is not lost. LagrangeBench reads one sequence
length per split, so trajectories of a split are cut to the shortest one; trajectories with
emitters (particles born later) are refused, as LagrangeBench has a fixed particle set.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from .dataset import Dataset
from ..outputs import atomic_dir, check_dir

FLUID, SOLID_WALL = 0, 1


def export_lagrangebench(splits: dict, out_dir, connectivity_radius: float | None = None,
                         overwrite: bool = False) -> dict:
    """``splits``: {"train": path, "valid": path, "test": path} (any subset, train needed for
    the statistics). Returns the metadata written. The files are written into a temporary
    directory that replaces ``out_dir`` at the end (an existing non-empty ``out_dir`` only
    with ``overwrite``), so it never mixes two exports."""
    if "train" not in splits:
        raise DcdcError("export-lagrangebench needs a --train dataset (statistics come from it)")
    check_dir(out_dir, overwrite=overwrite)
    Path(out_dir).parent.mkdir(parents=True, exist_ok=True)
    with atomic_dir(out_dir, overwrite=overwrite) as tmp:
        return _export(splits, tmp, connectivity_radius)


def _export(splits: dict, out: Path, connectivity_radius: float | None) -> dict:
    import h5py
    meta, seq = {}, {}
    stats = {"vel": [], "acc": []}
    bounds_lo, bounds_hi, nmax = None, None, 0
    for split, path in splits.items():
        ds = Dataset(path)
        if not len(ds):
            raise DcdcError(f"{path}: no finished trajectories to export")
        trajs = list(ds)
        for t in trajs:
            if (t.birth > 0).any():
                raise DcdcError(f"{t.name}: has emitted particles; LagrangeBench needs a fixed particle set")
            if np.isfinite(t.death).any():
                raise DcdcError(f"{t.name}: particles were removed (on_escape = remove); "
                                f"LagrangeBench needs a fixed particle set")
        dims = {t.dim for t in trajs}
        dts = {round(t.frame_dt, 9) for t in trajs}
        radii = {t.radius for t in trajs}
        if len(dims) > 1 or len(dts) > 1 or len(radii) > 1:
            raise DcdcError(f"{path}: trajectories differ in dim/frame_dt/radius; export one kind at a time")
        if meta and (meta["dim"] != dims.pop() or abs(meta["dt"] - dts.pop()) > 1e-12):
            raise DcdcError(f"{path}: differs in dim or frame_dt from the other splits")
        t0 = trajs[0]
        meta.setdefault("solvers", set()).update(str(t.attrs.get("solver", "")) for t in trajs)
        meta.setdefault("dim", t0.dim)
        meta.setdefault("dt", t0.frame_dt)
        meta.setdefault("dx", 2 * t0.radius)
        T = min(t.n_frames for t in trajs)
        seq[split] = (T, len(trajs))
        with h5py.File(out / f"{split}.h5", "w") as f:
            for k, t in enumerate(trajs):
                x = t.position[:T]
                w = t.wall_x
                pos = np.concatenate([x, np.broadcast_to(w[None], (T,) + w.shape)], axis=1)
                g = f.create_group(f"{k:05d}")
                g.create_dataset("position", data=pos.astype(np.float32))
                g.create_dataset("particle_type", data=np.concatenate(
                    [np.full(len(t.phase), FLUID), np.full(len(w), SOLID_WALL)]).astype(np.int32))
                g.create_dataset("phase", data=np.concatenate([t.phase, np.full(len(w), -1)]).astype(np.int32))
                g.create_dataset("density", data=np.concatenate([t.density, np.zeros(len(w))]).astype(np.float32))
                g.attrs["source"] = f"{ds.path}:{t.name}"
                nmax = max(nmax, pos.shape[1])
                lo, hi = pos.reshape(-1, t0.dim).min(0), pos.reshape(-1, t0.dim).max(0)
                bounds_lo = lo if bounds_lo is None else np.minimum(bounds_lo, lo)
                bounds_hi = hi if bounds_hi is None else np.maximum(bounds_hi, hi)
                if split == "train":
                    vel = np.diff(x, axis=0)  # LagrangeBench: per-step displacements
                    acc = np.diff(vel, axis=0)
                    stats["vel"].append(vel.reshape(-1, t0.dim))
                    stats["acc"].append(acc.reshape(-1, t0.dim))
    vel = np.concatenate(stats["vel"])
    acc = np.concatenate(stats["acc"])
    r = meta["dx"] / 2
    meta.update({
        "case": "dcdc_multiphase", "solver": "; ".join(sorted(meta.pop("solvers"))),
        "t_end": float(meta["dt"] * (seq["train"][0] - 1)), "write_every": 1,
        "sequence_length_train": seq["train"][0], "num_trajs_train": seq["train"][1],
        "sequence_length_test": seq.get("test", seq.get("valid", seq["train"]))[0],
        "num_trajs_test": seq.get("test", (0, 0))[1],
        "sequence_length_valid": seq.get("valid", (0, 0))[0], "num_trajs_valid": seq.get("valid", (0, 0))[1],
        "num_particles_max": int(nmax),
        "periodic_boundary_conditions": [False] * meta["dim"],
        "bounds": [[float(a), float(b)] for a, b in zip(bounds_lo, bounds_hi)],
        "default_connectivity_radius": float(connectivity_radius or 4.5 * r),
        "vel_mean": vel.mean(0).tolist(), "vel_std": vel.std(0).tolist(),
        "acc_mean": acc.mean(0).tolist(), "acc_std": acc.std(0).tolist(),
        "particle_types": {"FLUID": FLUID, "SOLID_WALL": SOLID_WALL},
        "extra_arrays": {"phase": "phase index per particle (-1: wall)",
                         "density": "rest density [kg/m^3] per particle (0: wall)"},
    })
    (out / "metadata.json").write_text(json.dumps(meta, indent=2))
    return meta
