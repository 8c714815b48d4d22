"""Export to the LagrangeBench dataset layout (tumaer/lagrangebench 0.2.0, ``H5Dataset`` in
``lagrangebench/data/data.py``; its generator ``data_gen/lagrangebench_data/gen_dataset.py``).

A directory with

* ``train.h5`` / ``valid.h5`` / ``test.h5``: groups ``00000``, ``00001``, ... each holding
  ``position`` [T, P, d] float32 and ``particle_type`` [P] int32, P = ``num_particles_max``
  for every trajectory: the fluid particles, then the wall particles (static), then static
  padding particles of LagrangeBench's ``NodeType.PAD_VALUE`` (-1), the type its own
  ``H5Dataset._matscipy_pad`` appends. So every sample has one shape and its default
  ``numpy_collate`` stacks batches of any size. Padding particles are kinematic there (no
  loss, fixed in rollouts), but its ``case_builder`` (0.2.0) takes every particle into the
  neighbour search whatever ``neighbors.backend`` says (it builds jax-md's neighbour list,
  which ignores ``backend`` and ``num_particles``): piled at one point, as its own padding
  is, they would all be neighbours of each other (P_pad^2 edges) and crowd one cell. So
  ours stand on a lattice (:func:`pad_lattice`) beyond the far x side, at least one
  connectivity radius from every particle and ``1.2`` radii from each other: no edge but
  their self-edges, at most a few per cell. ``bounds`` include that strip; without
  padding (all trajectories of one size) there is none.
* ``particle_type``: LagrangeBench's ``NodeType`` (``lagrangebench/utils.py``): walls are
  ``SOLID_WALL`` (1, kinematic: never predicted, kept fixed in rollouts); fluid phase k of a
  trajectory has type ``PHASE_TYPES[k]``: phase 0 is ``FLUID`` (0), phases 1-5 are 4-8
  (types 1-3 are walls and rigid bodies there, and its models embed ``NodeType.SIZE`` = 9
  types). The rest density of each phase, which differs between random scenes, is in
  ``metadata.json`` per trajectory and in each group (attributes ``phase_densities``,
  ``phase_names``), and per particle in the extra arrays ``phase`` (-1: wall or padding)
  and ``density`` [kg/m^3] (0: wall or padding), which LagrangeBench ignores.
* ``metadata.json`` with the keys LagrangeBench reads (``dim``, ``dt`` = frame interval,
  ``write_every`` = 1, ``dx`` = particle spacing 2 r, ``bounds``,
  ``periodic_boundary_conditions``, ``default_connectivity_radius``,
  ``num_particles_max``, ``vel_mean/std`` and ``acc_mean/std`` of the per-frame
  displacements and their differences of the fluid particles of the train split) and its
  generator's ``sequence_length_SPLIT`` = frames - 1 (the last frame is only a target).
* ``force.py``: LagrangeBench loads ``force_fn(r)`` from it as the external force feature
  (its dam-break dataset returns ``[0, -1]``); ours returns the trajectories' gravity in
  m/s^2. Written when the gravity is not zero; all trajectories must share it.

Positions are shifted so that ``bounds`` start at 0 (as in LagrangeBench's datasets; its
jax-md cell lists span [0, bounds extent]): LagrangeBench position = dcdc position -
``origin`` (in ``metadata.json``), with a margin of one particle radius on every side
(``particle_bounds``; ``bounds`` add the padding strip in x).

LagrangeBench reads one sequence length per split (the first trajectory's), so the
trajectories of a split are cut to the shortest one. Trajectories with emitters (particles
born later) or removed particles are refused: LagrangeBench has a fixed particle set.
LagrangeBench infers the dataset name from a directory named ``{2D|3D}_ABC...`` and warns
for other names; :func:`dataset_name` gives one (``2D_DCD_563_50every1``).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from .dataset import Dataset
from ..outputs import atomic_dir, atomic_h5, check_dir, write_text

PAD_VALUE, FLUID, SOLID_WALL = -1, 0, 1   # lagrangebench.utils.NodeType
PHASE_TYPES = (FLUID, 4, 5, 6, 7, 8)      # particle_type of phase 0, 1, ...
NAME_PATTERN = re.compile(r"(?:2D|3D)_[A-Z]{3}")  # lagrangebench.data.get_dataset_name_from_path

FORCE_PY = '''"""External force of this dataset for LagrangeBench (lagrangebench.data.H5Dataset loads
force_fn from this file): the gravity of the exported dcdc trajectories, in m/s^2, the
same at every position."""
import jax.numpy as jnp

GRAVITY = {gravity!r}  # m/s^2


def force_fn(r, t=None, **kwargs):
    return jnp.asarray(GRAVITY, dtype=r.dtype)
'''


def dataset_name(meta: dict) -> str:
    """A directory name LagrangeBench recognises: ``{dim}D_DCD_{num_particles_max}_
    {sequence_length_train}every1`` (its own: ``2D_TGV_2500_10kevery100``)."""
    return f"{meta['dim']}D_DCD_{meta['num_particles_max']}_{meta['sequence_length_train']}every1"


def pad_lattice(extent, cutoff: float, count: int) -> tuple[np.ndarray, float]:
    """``count`` padding positions [count, d] beyond x = ``extent[0]`` for particles inside
    [0, ``extent``]: layers x = extent[0] + cutoff, + s, + 2 s, ... (s = 1.2 ``cutoff``),
    each a grid of spacing >= s over the other axes. Returns them and the x extent that
    holds them (the last layer + s / 2)."""
    extent = np.asarray(extent, np.float64)
    s = 1.2 * cutoff
    rows = [max(1, int(e // s)) for e in extent[1:]]
    grid = np.stack(np.meshgrid(*[(np.arange(n) + 0.5) * e / n for n, e in zip(rows, extent[1:])],
                                indexing="ij"), -1).reshape(-1, len(rows))
    layers = max(1, -(-count // len(grid)))
    x = extent[0] + cutoff + s * np.arange(layers)
    pts = np.concatenate([np.repeat(x, len(grid))[:, None], np.tile(grid, (layers, 1))], 1)
    return pts[:count], float(x[-1] + s / 2)


def export_lagrangebench(splits: dict, out_dir, connectivity_radius: float | None = None,
                         overwrite: bool = False, warn=None) -> dict:
    """``splits``: {"train": path, "valid": path, "test": path} (any subset, train needed for
    the statistics). Returns the metadata written. The files are written into a temporary
    directory that replaces ``out_dir`` at the end (an existing non-empty ``out_dir`` only
    with ``overwrite``), so it never mixes two exports; each split's file is built in memory
    and written whole (:func:`dcdc.outputs.atomic_h5`), so a full disk is one error line and
    leaves nothing behind. ``warn(text)`` is called when the name of ``out_dir`` would make
    LagrangeBench warn."""
    if "train" not in splits:
        raise DcdcError("export-lagrangebench needs a --train dataset (statistics come from it)")
    check_dir(out_dir, overwrite=overwrite)
    Path(out_dir).parent.mkdir(parents=True, exist_ok=True)
    with atomic_dir(out_dir, overwrite=overwrite) as tmp:
        meta = _export(splits, tmp, connectivity_radius)
    name = Path(out_dir).resolve().name
    if warn and not NAME_PATTERN.search(name):
        warn(f"LagrangeBench warns about a dataset directory named {name!r} (it wants "
             f"{{2D|3D}}_ABC...): rename it, e.g. to {dataset_name(meta)}, or pass name= to its H5Dataset")
    return meta


def _scan(splits: dict) -> dict:
    """Check every trajectory; per split: (dataset, trajectories, frames kept)."""
    out, common = {}, {}
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
            if len(t.phases) > len(PHASE_TYPES):
                raise DcdcError(f"{t.name}: {len(t.phases)} phases; LagrangeBench has particle "
                                f"types for at most {len(PHASE_TYPES)}")
            if t.n_frames < 2:
                raise DcdcError(f"{t.name}: {t.n_frames} frame; LagrangeBench needs at least 2")
            key = {"dim": t.dim, "dt": round(t.frame_dt, 9), "radius": t.radius,
                   "gravity": tuple(np.round(t.gravity[:t.dim], 9).tolist())}
            for k, v in key.items():
                if common.setdefault(k, (v, f"{path}:{t.name}"))[0] != v:
                    raise DcdcError(f"{path}:{t.name}: {k} {v} differs from {common[k][0]} of "
                                    f"{common[k][1]}; LagrangeBench takes one {k} per dataset")
        out[split] = (ds, trajs, min(t.n_frames for t in trajs))
    return out


def _export(splits: dict, out: Path, connectivity_radius: float | None) -> dict:
    scanned = _scan(splits)
    t0 = scanned["train"][1][0]
    dim, r, dt = t0.dim, t0.radius, t0.frame_dt
    gravity = [float(g) for g in t0.gravity[:dim]]
    # pass 1: the particle count to pad to and the box over all splits
    lo, hi, nmax, nmin = np.full(dim, np.inf), np.full(dim, -np.inf), 0, np.inf
    for ds, trajs, T in scanned.values():
        for t in trajs:
            x = t._get("position", slice(0, T))  # uncached: one trajectory in memory at a time
            pts = np.concatenate([x.reshape(-1, dim), t.wall_x])
            lo, hi = np.minimum(lo, pts.min(0)), np.maximum(hi, pts.max(0))
            nmax = max(nmax, t.n_particles + len(t.wall_x))
            nmin = min(nmin, t.n_particles + len(t.wall_x))
    origin = np.round(lo - r, 9)  # nanometres: no float32 digits in metadata.json
    extent = np.round(hi + r - origin, 9)
    cutoff = float(connectivity_radius or 4.5 * r)
    box = extent.copy()
    pads = np.zeros((0, dim))
    if nmax > nmin:
        pads, box[0] = pad_lattice(extent, cutoff, nmax - nmin)
    _check_memory(scanned, nmax, dim)
    stats = {"vel": _Moments(dim), "acc": _Moments(dim)}
    listing = {}
    for split, (ds, trajs, T) in scanned.items():
        rows = listing[split] = []
        with atomic_h5(out / f"{split}.h5") as f:  # built in memory: a full disk is one line
            for k, t in enumerate(trajs):
                x = t._get("position", slice(0, T)).astype(np.float64) - origin
                w = np.asarray(t.wall_x, np.float64) - origin
                n, m = t.n_particles, len(w)
                pos = np.empty((T, nmax, dim), np.float32)
                pos[:, :n], pos[:, n:n + m] = x, w
                pos[:, n + m:] = pads[:nmax - n - m]
                ptype = np.full(nmax, PAD_VALUE, np.int32)
                ptype[:n], ptype[n:n + m] = np.asarray(PHASE_TYPES)[t.phase], SOLID_WALL
                phase = np.full(nmax, -1, np.int32)
                phase[:n] = t.phase
                dens = np.zeros(nmax, np.float32)
                dens[:n] = t.density
                g = f.create_group(f"{k:05d}")
                g.create_dataset("position", data=pos)
                g.create_dataset("particle_type", data=ptype)
                g.create_dataset("phase", data=phase)
                g.create_dataset("density", data=dens)
                info = {"key": f"{k:05d}", "source": f"{ds.path}:{t.name}", "num_fluid": n,
                        "num_walls": m, "phase_names": [p.name for p in t.phases],
                        "phase_densities": [p.density for p in t.phases]}
                for a in ("source", "num_fluid", "num_walls", "phase_densities"):
                    g.attrs[a] = info[a]
                g.attrs["phase_names"] = json.dumps(info["phase_names"])
                rows.append(info)
                if split == "train":
                    xf = pos[:, :n].astype(np.float64)  # the stored float32, as LagrangeBench reads it
                    vel = np.diff(xf, axis=0)           # per-frame displacements
                    stats["vel"].add(vel.reshape(-1, dim))
                    stats["acc"].add(np.diff(vel, axis=0).reshape(-1, dim))
    if gravity and any(gravity):
        write_text(out / "force.py", FORCE_PY.format(gravity=tuple(gravity)))
    seq = {s: (T - 1, len(trajs)) for s, (_, trajs, T) in scanned.items()}
    test = seq.get("test", seq.get("valid", seq["train"]))
    n_phases = max(len(t.phases) for _, trajs, _ in scanned.values() for t in trajs)
    solvers = sorted({str(t.attrs.get("solver", "")) for _, trajs, _ in scanned.values() for t in trajs})
    meta = {
        "case": "DCD", "solver": "; ".join(solvers),
        "description": "dcdc immiscible multiphase liquids (dcdc dataset export-lagrangebench)",
        "dim": dim, "dt": dt, "write_every": 1, "dx": 2 * r,
        "t_end": float(dt * seq["train"][0]),
        "sequence_length_train": seq["train"][0], "num_trajs_train": seq["train"][1],
        "sequence_length_test": test[0], "num_trajs_test": seq.get("test", (0, 0))[1],
        "sequence_length_valid": seq.get("valid", (0, 0))[0],
        "num_trajs_valid": seq.get("valid", (0, 0))[1],
        "num_particles_max": int(nmax),
        "periodic_boundary_conditions": [False] * dim,
        "bounds": [[0.0, float(b)] for b in box],
        "origin": origin.tolist(),
        "particle_bounds": [[0.0, float(b)] for b in extent],
        "padding": {"count_max": int(nmax - nmin),
                    "first_x": float(extent[0] + cutoff) if len(pads) else None,
                    "spacing": 1.2 * cutoff if len(pads) else None},
        "default_connectivity_radius": cutoff,
        "vel_mean": stats["vel"].mean.tolist(), "vel_std": stats["vel"].std.tolist(),
        "acc_mean": stats["acc"].mean.tolist(), "acc_std": stats["acc"].std.tolist(),
        "gravity": gravity,
        "particle_types": {"PAD_VALUE": PAD_VALUE, "FLUID": FLUID, "SOLID_WALL": SOLID_WALL,
                           **{f"FLUID_PHASE_{k}": PHASE_TYPES[k] for k in range(1, n_phases)}},
        "particle_type_of_phase": list(PHASE_TYPES[:n_phases]),
        "extra_arrays": {"phase": "phase index per particle (-1: wall or padding)",
                         "density": "rest density [kg/m^3] per particle (0: wall or padding)"},
        "units": {"length": "m", "time": "s", "density": "kg/m^3", "gravity": "m/s^2"},
        "trajectories": listing,
    }
    write_text(out / "metadata.json", json.dumps(meta, indent=1))
    return meta


def split_bytes(T: int, count: int, nmax: int, dim: int) -> int:
    """Bytes of one split's arrays: positions [T, nmax, dim] float32 and the per-particle
    type, phase and density (4 bytes each) of ``count`` trajectories."""
    return count * (T * nmax * dim * 4 + 3 * nmax * 4)


def _check_memory(scanned: dict, nmax: int, dim: int) -> None:
    """A split's file is built in memory (:func:`dcdc.outputs.atomic_h5`), one split at a
    time: refuse a split larger than half this machine's memory before writing any."""
    from ..scene.budget import physical_memory
    mem = physical_memory()
    for split, (_, trajs, T) in scanned.items():
        size = split_bytes(T, len(trajs), nmax, dim)
        if mem and size > 0.5 * mem:
            raise DcdcError(f"the {split} split ({len(trajs)} trajectories of {T} frames x "
                            f"{nmax} particles) makes a {size / 2**30:.1f} GiB {split}.h5, more "
                            f"than half of this machine's {mem / 2**30:.1f} GiB of memory, "
                            f"which builds it; export fewer trajectories per split")


class _Moments:
    """Mean and standard deviation per column over row blocks (Chan et al.'s pairwise
    update of count, mean and sum of squared deviations), without keeping the rows."""

    def __init__(self, dim: int):
        self.n, self._mean, self._m2 = 0, np.zeros(dim), np.zeros(dim)

    def add(self, rows: np.ndarray) -> None:
        if not len(rows):
            return
        n, mean = len(rows), rows.mean(0)
        m2 = ((rows - mean) ** 2).sum(0)
        total = self.n + n
        delta = mean - self._mean
        self._m2 += m2 + delta ** 2 * self.n * n / total
        self._mean += delta * n / total
        self.n = total

    @property
    def mean(self) -> np.ndarray:
        return self._mean

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(self._m2 / max(self.n, 1))
