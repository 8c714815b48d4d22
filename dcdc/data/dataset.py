"""The trajectory dataset (docs/datasets.md): HDF5, one group per trajectory.

On disk a dataset is either
- a **directory** of per-trajectory files ``NAME.h5`` (what ``dcdc generate`` writes: each
  file is written under a temporary name and renamed when complete, so a killed run never
  leaves a file that reads as finished) plus an informative ``dataset.json`` index, or
- a **single file** ``*.h5`` holding many trajectory groups (``dcdc dataset merge``).

Each trajectory group ``/NAME`` holds:

| dataset | shape | dtype | meaning |
| --- | --- | --- | --- |
| ``position`` | [T, N, d] | float32 | fluid positions [m] at ``time`` (frame 0 = initial state) |
| ``velocity`` | [T, N, d] | float32 | fluid velocities [m/s] |
| ``time`` | [T] | float64 | simulated time of each frame [s] |
| ``phase`` | [N] | int32 | phase index of each fluid particle |
| ``density`` | [N] | float32 | rest density ρ₀ of each particle [kg/m³] |
| ``birth`` | [N] | float32 | emission time (0 = present at t = 0) [s] |
| ``death`` | [N] | float64 | removal time (inf = never removed) [s]; absent in older files |
| ``wall_position``, ``wall_normal`` | [M, d] | float32 | static wall particles, normals into the fluid |

and attributes (metadata): ``dim``, ``radius``, ``frame_dt``, ``n_frames``, ``gravity``,
``domain_min``/``domain_max``, ``phase_names``/``_densities``/``_viscosities``/``_colors``,
``units`` (JSON), ``solver``, ``solver_settings`` (JSON), ``scene``, ``scene_toml`` (the full
scene file), ``scene_dim``, ``resolution``, ``seed``, ``split``, ``dcdc_version``,
``git_commit``, ``created``, ``wall_time_s``, ``solver_stats`` (JSON), ``max_density_ratio``,
``removed`` (particles with a finite ``death``), ``attrs_sha256`` and ``complete`` = 1,
written last.

A particle takes part in frame k when ``birth <= time[k] < death``
(:meth:`Trajectory.active`); outside that interval its stored position is its nozzle
(before birth) or where it left the domain (after removal, frozen).

Integrity (format version 2): every non-empty array is stored with HDF5's Fletcher-32
checksum filter, which HDF5 verifies on every read (a flipped bit makes the read fail
instead of returning wrong numbers), and ``attrs_sha256`` is a SHA-256 digest of the
group's other attributes, checked when a trajectory is opened. Files of format version 1
(no checksums) stay readable; :func:`verify` reports them as not verifiable.
"""
from __future__ import annotations

import hashlib
import json
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from ..particles import ParticleSystem, Phase, active_mask
from ..outputs import TMP_MARK, atomic_dir, atomic_h5

FORMAT = "dcdc-dataset"
MAX_SPEED = 1e3  # [m/s] beyond any liquid flow here (the SPH solver's own bound is 50 m/s)
MAX_POSITION = 1e6  # [m]
FORMAT_VERSION = 2  # 2: Fletcher-32 on every array, attrs_sha256
UNITS = {"length": "m", "time": "s", "velocity": "m/s", "density": "kg/m^3",
         "viscosity": "m^2/s (kinematic)", "gravity": "m/s^2"}


def _h5():
    import h5py
    return h5py


def _open(path, mode="r"):
    h5py = _h5()
    try:
        return h5py.File(path, mode)
    except FileNotFoundError:
        raise DcdcError(f"{path}: no such file") from None
    except OSError as e:
        if "unable to lock file" in str(e):  # HDF5's file lock: another process writes it
            raise DcdcError(f"{path}: another process has it open for writing (HDF5 file "
                            f"lock); try again when it is done") from None
        raise DcdcError(f"{path}: not a readable HDF5 file (truncated or corrupt?): "
                        f"{_first_line(e)}") from None


def _first_line(e: BaseException) -> str:
    return (str(e).strip().splitlines() or [type(e).__name__])[0].strip("'\"")


# what h5py raises for a damaged file: OSError (bad data, failed checksum), KeyError and
# RuntimeError (damaged object headers, heaps, symbol tables), ValueError (bad messages)
H5_DAMAGE = (OSError, KeyError, RuntimeError, ValueError)


@contextmanager
def _reading(path, what: str = ""):
    """Open ``path`` for reading; any HDF5 error inside becomes a one-line DcdcError that
    calls the file corrupt (never a traceback, never a silent "unfinished")."""
    f = _open(path)
    try:
        yield f
    except DcdcError:
        raise
    except H5_DAMAGE as e:
        raise DcdcError(f"{path}: corrupt HDF5 file{(' (' + what + ')') if what else ''}: "
                        f"{_first_line(e)}") from None
    finally:
        try:
            f.close()
        except Exception:  # closing a damaged file can fail too; nothing left to save
            pass


def attrs_digest(attrs) -> str:
    """SHA-256 of a trajectory group's attributes (all but ``attrs_sha256`` and
    ``complete``), in a canonical form: sorted keys, values as JSON of their Python value."""
    h = hashlib.sha256()
    for k in sorted(attrs):
        if k in ("attrs_sha256", "complete"):
            continue
        v = _attr(attrs[k])
        v = v.tolist() if isinstance(v, np.ndarray) else v
        h.update(json.dumps([k, v], sort_keys=True, default=str).encode())
    return h.hexdigest()


def max_density_ratio(density, birth=None, t_end: float | None = None) -> float:
    """Largest rest-density ratio ρ_max / ρ_min over the particles present (born by
    ``t_end``); 1 for a single density or no particles."""
    d = np.asarray(density, dtype=np.float64)
    if birth is not None and t_end is not None:
        d = d[np.asarray(birth) <= t_end + 1e-9]
    return float(d.max() / d.min()) if len(d) and d.min() > 0 else 1.0


# ------------------------------------------------------------------ writing
def write_trajectory(path, name: str, frames_x, frames_v, times, system: ParticleSystem,
                     attrs: dict) -> Path:
    """Write one trajectory atomically to ``path`` (a ``.h5`` file holding group ``name``):
    built in memory, written to a temporary file in the same directory, fsync-ed, then
    renamed over ``path`` (:func:`dcdc.outputs.atomic_h5`)."""
    path = Path(path)
    with atomic_h5(path) as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        g = f.create_group(name)
        write_group(g, frames_x, frames_v, times, system, attrs)
    return path


def write_group(g, frames_x, frames_v, times, system: ParticleSystem, attrs: dict) -> None:
    x = np.asarray(frames_x, dtype=np.float32)
    v = np.asarray(frames_v, dtype=np.float32)
    T, N, d = x.shape if x.ndim == 3 else (len(x), 0, system.dim)
    chunks = (1, max(N, 1), d) if N else None

    def put(key, arr, **kw):
        # Fletcher-32 on every non-empty array (HDF5 checks it on each read); HDF5 cannot
        # chunk an empty array, and an empty array has nothing to damage
        g.create_dataset(key, data=arr, fletcher32=bool(arr.size), **kw)
    put("position", x, chunks=chunks, compression="lzf" if N else None)
    put("velocity", v, chunks=chunks, compression="lzf" if N else None)
    times = np.asarray(times, dtype=np.float64)
    put("time", times)
    put("phase", system.phase.astype(np.int32))
    put("density", system.rest_density.astype(np.float32))
    put("birth", system.birth.astype(np.float32))
    # float64: a removal at the last substep of a frame lies on the frame's time exactly,
    # and float32 would move it past that time (the particle would read as active there)
    put("death", system.death.astype(np.float64))
    put("wall_position", system.wall_x.astype(np.float32))
    put("wall_normal", system.wall_n.astype(np.float32))
    meta = {
        "max_density_ratio": max_density_ratio(system.rest_density, system.birth,
                                               float(times[-1]) if len(times) else 0.0),
        "removed": system.n_removed,
        "dim": system.dim, "radius": system.radius, "n_frames": T - 1,
        "gravity": system.gravity, "domain_min": system.domain[0], "domain_max": system.domain[1],
        "phase_names": json.dumps([p.name for p in system.phases]),
        "phase_densities": np.array([p.density for p in system.phases]),
        "phase_viscosities": np.array([p.viscosity for p in system.phases]),
        "phase_colors": np.array([p.color for p in system.phases]),
        "units": json.dumps(UNITS),
    }
    meta.update(attrs)
    for k, val in meta.items():
        if isinstance(val, (dict, list)):
            val = json.dumps(val)
        if val is None:
            val = ""
        g.attrs[k] = val
    g.attrs["attrs_sha256"] = attrs_digest(g.attrs)  # of the values as stored, read back
    g.attrs["complete"] = 1  # last: a group without it is never read as finished


def is_complete(path) -> bool:
    """True when ``path`` is a finished trajectory file (readable, every group complete)."""
    try:
        with _h5().File(path, "r") as f:
            groups = [f[k] for k in f.keys()]
            return bool(groups) and all(int(g.attrs.get("complete", 0)) == 1 for g in groups)
    except Exception:
        return False


def removed_count(path, name: str) -> int:
    """The ``removed`` attribute of trajectory ``name`` in the file ``path`` (0 when absent:
    written before removal existed), without reading its arrays."""
    with _reading(path, name) as f:
        return int(_attr(f[name].attrs.get("removed", 0)))


# ------------------------------------------------------------------ reading
@dataclass
class _Ref:
    file: Path
    group: str


def _check_shapes(ref: _Ref, g, attrs: dict) -> None:
    """The arrays of trajectory group ``g`` agree with each other and with ``dim``:
    position and velocity [T, N, d], time [T], per-particle arrays [N]."""
    where = f"{ref.file}: trajectory {ref.group}"
    dim = attrs.get("dim")
    x = g["position"].shape
    empty = len(x) == 2 and x[1] == 0  # no fluid particle, as older writers stored it
    if not empty and (len(x) != 3 or (dim is not None and x[2] != int(dim) and x[1] > 0)):
        raise DcdcError(f"{where}: position has shape {list(x)}, not [frames, particles, "
                        f"{dim if dim is not None else 'd'}]")
    if g["velocity"].shape != x:
        raise DcdcError(f"{where}: velocity has shape {list(g['velocity'].shape)}, position "
                        f"{list(x)}")
    if "time" in g and g["time"].shape != x[:1]:
        raise DcdcError(f"{where}: {g['time'].shape[0] if g['time'].ndim else 0} times for "
                        f"{x[0]} frames")
    for key in ("phase", "density", "birth", "death"):
        if key in g and g[key].shape != x[1:2]:
            raise DcdcError(f"{where}: {key} has shape {list(g[key].shape)} for {x[1]} "
                            f"particles")


class Trajectory:
    """One trajectory. Arrays are read from disk on first access and cached."""

    def __init__(self, ref: _Ref):
        self.ref = ref
        self.name = ref.group
        with _reading(ref.file, ref.group) as f:
            if ref.group not in f:
                raise DcdcError(f"{ref.file}: no trajectory group {ref.group!r}")
            g = f[ref.group]
            missing = [k for k in ("position", "velocity", "phase", "wall_position") if k not in g]
            if missing:
                raise DcdcError(f"{ref.file}: trajectory {ref.group} lacks {', '.join(missing)}")
            self.attrs = {k: _attr(v) for k, v in g.attrs.items()}
            self.shape = g["position"].shape
            _check_shapes(ref, g, self.attrs)
            self._has_death = "death" in g
            stored = self.attrs.get("attrs_sha256")
            if stored is not None and stored != attrs_digest(g.attrs):
                raise DcdcError(f"{ref.file}: corrupt trajectory {ref.group}: its metadata does not "
                                "match their checksum (attrs_sha256)")
        self._cache = {}

    # metadata
    @property
    def dim(self) -> int:
        return int(self.attrs["dim"])

    @property
    def radius(self) -> float:
        return float(self.attrs["radius"])

    @property
    def frame_dt(self) -> float:
        return float(self.attrs["frame_dt"])

    @property
    def n_frames(self) -> int:
        """Number of stored frames T (initial state included)."""
        return int(self.shape[0])

    @property
    def n_particles(self) -> int:
        return int(self.shape[1])

    @property
    def max_density_ratio(self) -> float:
        """ρ_max / ρ_min of the rest densities of the particles present by the last frame
        (stored as an attribute since format 2; computed for older files)."""
        if "max_density_ratio" in self.attrs:
            return float(self.attrs["max_density_ratio"])
        t = self.time
        return max_density_ratio(self.density, self.birth, float(t[-1]) if len(t) else 0.0)

    @property
    def gravity(self) -> np.ndarray:
        return np.asarray(self.attrs["gravity"], dtype=np.float64)

    @property
    def phases(self) -> list[Phase]:
        names = json.loads(self.attrs["phase_names"])
        return [Phase(n, float(d), float(v), tuple(float(c) for c in col)) for n, d, v, col in
                zip(names, self.attrs["phase_densities"], self.attrs["phase_viscosities"],
                    self.attrs["phase_colors"])]

    def _get(self, key, sl=None):
        if sl is None and key in self._cache:
            return self._cache[key]
        with _open(self.ref.file) as f:
            try:
                ds = f[self.ref.group][key]
                arr = ds[()] if sl is None else ds[sl]
            except H5_DAMAGE as e:  # a failed Fletcher-32 check is an OSError here
                raise DcdcError(f"{self.ref.file}: cannot read {self.ref.group}/{key} "
                                f"(corrupt or truncated): {_first_line(e)}") from None
        if sl is None:
            self._cache[key] = arr
        return arr

    position = property(lambda self: self._get("position"))
    velocity = property(lambda self: self._get("velocity"))
    time = property(lambda self: self._get("time"))
    phase = property(lambda self: self._get("phase"))
    density = property(lambda self: self._get("density"))
    birth = property(lambda self: self._get("birth"))

    @property
    def death(self) -> np.ndarray:
        """Removal time of each particle [N] (inf = never removed; all inf in files written
        before removal existed)."""
        return self._get("death") if self._has_death else np.full(self.n_particles, np.inf)

    @property
    def removed(self) -> int:
        """Number of particles removed during the run (left the domain)."""
        if "removed" in self.attrs:
            return int(self.attrs["removed"])
        return int(np.isfinite(self.death).sum())

    def active(self, frame: int) -> np.ndarray:
        """Boolean mask [N] of the particles taking part in ``frame``: born and not yet
        removed, ``birth <= time[frame] < death`` (:func:`dcdc.particles.active_mask`)."""
        return active_mask(self.birth, self.death, float(self.time[frame]))
    wall_x = property(lambda self: self._get("wall_position"))
    wall_n = property(lambda self: self._get("wall_normal"))

    def window(self, start: int, length: int) -> dict:
        """Frames ``start .. start+length-1``: position/velocity [L, N, d] plus the static
        per-particle arrays (a training sample for an unrolled loss)."""
        if not (0 <= start and start + length <= self.n_frames):
            raise DcdcError(f"window {start}..{start + length - 1} outside {self.name} "
                            f"(frames 0..{self.n_frames - 1})")
        sl = slice(start, start + length)
        x, v = self._get("position", sl), self._get("velocity", sl)
        self.check_values(x, v, start)
        return {"position": x, "velocity": v,
                "time": self.time[sl], "phase": self.phase, "density": self.density,
                "birth": self.birth, "death": self.death, "wall_position": self.wall_x, "wall_normal": self.wall_n,
                "gravity": self.gravity, "radius": self.radius, "frame_dt": self.frame_dt}

    def check_values(self, x=None, v=None, start: int = 0) -> None:
        """One-line :class:`DcdcError` naming the file, trajectory and frame when positions
        ``x`` or velocities ``v`` [F, N, d] (frames ``start`` on; default: every frame) are
        non-finite (a diverged run: training would see only NaN losses) or beyond
        :data:`MAX_POSITION` / :data:`MAX_SPEED` (not liquid in metres and seconds: a
        neighbour grid or a network cannot take them)."""
        if x is None:
            x, v = self._get("position"), self._get("velocity")
        for key, a, bound, unit in (("positions", x, MAX_POSITION, "m"),
                                    ("velocities", v, MAX_SPEED, "m/s")):
            a = np.asarray(a).reshape(len(a), -1)
            bad = ~np.isfinite(a).all(1)
            what = "non-finite {k} (a diverged run)"
            if not bad.any():
                bad = (np.abs(a) > bound).any(1)
                what = f"{{k}} beyond {bound:g} {unit} (not a liquid in metres and seconds)"
            if bad.any():
                k = start + int(np.flatnonzero(bad)[0])
                raise DcdcError(f"{self.ref.file}: trajectory {self.name} has "
                                f"{what.format(k=key)} in frame {k}; remove it from the dataset")

    def system(self, frame: int = 0) -> ParticleSystem:
        """The state at ``frame`` as a :class:`ParticleSystem` (e.g. to start a rollout)."""
        x = self._get("position", frame).astype(np.float64)
        v = self._get("velocity", frame).astype(np.float64)
        self.check_values(x[None], v[None], frame)
        return ParticleSystem(self.dim, self.radius, x, v, self.phase, self.phases,
                              self.wall_x, self.wall_n, self.gravity,
                              (self.attrs["domain_min"], self.attrs["domain_max"]),
                              self.birth.astype(np.float64), self.attrs.get("scene", self.name),
                              {"trajectory": self.name, "frame": frame}, death=self.death)

    def __repr__(self):
        return (f"Trajectory({self.name!r}, {self.dim}-D, {self.n_frames} frames, "
                f"{self.n_particles} fluid particles)")


def _attr(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _scan(path: Path) -> tuple[list[_Ref], list[str]]:
    """Trajectory references in a dataset directory or file, and names of unfinished ones."""
    refs, incomplete = [], []

    def groups(p: Path, f, keys):
        # a final-named file of format >= 2 is renamed into place only when complete, so a
        # group without the mark there is damage, not an unfinished run
        atomic = int(f.attrs.get("format_version", 1)) >= 2
        other = [k for k in keys if not isinstance(f[k], _h5().Group)]
        if other:
            raise DcdcError(f"{p}: not a dcdc dataset: {', '.join(other[:3])}"
                            f"{', …' if len(other) > 3 else ''} at its top level "
                            f"{'is' if len(other) == 1 else 'are'} not trajectory groups")
        for k in keys:
            if int(f[k].attrs.get("complete", 0)) == 1:
                refs.append(_Ref(p, k))
            elif atomic:
                raise DcdcError(f"{p}: corrupt trajectory {k}: its 'complete' mark is missing "
                                "in a file that is only ever written whole")
            else:
                incomplete.append(k)
    if path.is_dir():
        for p in sorted(path.glob("*.h5")):
            if p.name.startswith("."):
                continue
            with _reading(p) as f:
                groups(p, f, list(f.keys()))
        incomplete += [p.name for p in path.glob(f".*.h5{TMP_MARK}*")]
    elif path.is_file():
        with _reading(path) as f:
            if f.attrs.get("format", FORMAT) != FORMAT and "format" in f.attrs:
                raise DcdcError(f"{path}: not a dcdc dataset (format {f.attrs['format']!r})")
            groups(path, f, sorted(f.keys()))
    else:
        raise DcdcError(f"{path}: no such dataset (directory or .h5 file)")
    return refs, incomplete


class Dataset:
    """A dcdc trajectory dataset (directory of trajectory files or one merged file).

    ```python
    ds = Dataset("datasets/2d/train")
    for traj in ds.trajectories(): ...
    for i, start in ds.windows(length=3): sample = ds[i].window(start, 3)
    ```
    Unfinished trajectories (temporary files, groups without ``complete``) are skipped and
    listed in :attr:`incomplete`.
    """

    def __init__(self, path):
        self.path = Path(path)
        self._refs, self.incomplete = _scan(self.path)
        self._trajs: dict[str, Trajectory] = {}
        names = [r.group for r in self._refs]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise DcdcError(f"{self.path}: trajectory name(s) {', '.join(sorted(dup))} appear twice")

    @property
    def names(self) -> list[str]:
        return [r.group for r in self._refs]

    def __len__(self) -> int:
        return len(self._refs)

    def __getitem__(self, key) -> Trajectory:
        if isinstance(key, str):
            if key not in self.names:
                raise DcdcError(f"{self.path}: no trajectory {key!r}")
            key = self.names.index(key)
        ref = self._refs[key]
        if ref.group not in self._trajs:
            self._trajs[ref.group] = Trajectory(ref)
        return self._trajs[ref.group]

    def __iter__(self):
        return (self[i] for i in range(len(self)))

    def trajectories(self):
        return iter(self)

    def windows(self, length: int, stride: int = 1) -> list[tuple[int, int]]:
        """All (trajectory index, start frame) pairs of windows of ``length`` frames."""
        out = []
        for i in range(len(self)):
            T = self[i].n_frames
            out += [(i, s) for s in range(0, T - length + 1, stride)]
        return out

    def summary(self) -> dict:
        trajs = list(self)
        dims = sorted({t.dim for t in trajs})
        ratios = [t.max_density_ratio for t in trajs]
        return {
            "path": str(self.path), "trajectories": len(trajs), "incomplete": len(self.incomplete),
            "dims": dims, "frames": int(sum(t.n_frames for t in trajs)),
            "particles_min": int(min((t.n_particles for t in trajs), default=0)),
            "particles_max": int(max((t.n_particles for t in trajs), default=0)),
            "frame_dt": sorted({t.frame_dt for t in trajs}),
            "radius": sorted({t.radius for t in trajs}),
            "solvers": sorted({str(t.attrs.get("solver", "?")) for t in trajs}),
            "splits": sorted({str(t.attrs.get("split", "")) for t in trajs}),
            "phases_per_traj": sorted({len(t.phases) for t in trajs}),
            "density_ratio_max": max(ratios, default=1.0),
            "density_range": [float(min((t.density.min() for t in trajs if t.n_particles), default=0)),
                              float(max((t.density.max() for t in trajs if t.n_particles), default=0))],
            "wall_time_s": float(sum(float(t.attrs.get("wall_time_s", 0) or 0) for t in trajs)),
            "removed": int(sum(t.removed for t in trajs)),
            "stopped_rollouts": sorted(t.name for t in trajs
                                       if str(t.attrs.get("rollout_status", "")) == "stopped"),
            "bytes": int(sum(p.stat().st_size for p in {r.file for r in self._refs})),
        }


def verify_trajectory(traj: Trajectory) -> bool:
    """Read every array of ``traj`` in full, so HDF5 checks each chunk's Fletcher-32 sum
    (opening it already checked the metadata digest). True when everything carried a
    checksum, False for an older file without checksums; DcdcError on damage."""
    checked = True
    with _open(traj.ref.file) as f:
        try:
            g = f[traj.ref.group]
            for key in g:
                ds = g[key]
                if ds.size:
                    checked &= bool(ds.fletcher32)
                    for k in range(0, ds.shape[0], 256):  # a bounded slab at a time
                        ds[k:k + 256]
            checked &= "attrs_sha256" in g.attrs
        except H5_DAMAGE as e:
            raise DcdcError(f"{traj.ref.file}: corrupt trajectory {traj.name}: "
                            f"{_first_line(e)}") from None
    return checked


def verify(ds: Dataset) -> dict:
    """Check every trajectory of ``ds``: {"verified": names, "unverifiable": names written
    without checksums (format 1), "corrupt": {name: reason}}."""
    out = {"verified": [], "unverifiable": [], "corrupt": {}}
    for i, name in enumerate(ds.names):
        try:
            ok = verify_trajectory(ds[i])
        except DcdcError as e:
            out["corrupt"][name] = str(e)
            continue
        out["verified" if ok else "unverifiable"].append(name)
    return out


def merge(inputs, output, overwrite: bool = False) -> int:
    """Join datasets (directories or files, e.g. shards) into ``output``: a single ``.h5``
    file (written to a temporary name, then renamed) or, for any other name, a directory of
    trajectory files. Duplicate trajectory names are an error. Returns the count."""
    import shutil
    output = Path(output)
    sets = [Dataset(p) for p in inputs]
    names = [n for s in sets for n in s.names]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DcdcError(f"trajectory name(s) in more than one input: {', '.join(dup[:5])}")
    if output.exists() and not overwrite:
        raise DcdcError(f"{output} exists (use --overwrite)")
    for s in sets:  # copying moves raw chunks without checking them: check them first
        for t in s:
            verify_trajectory(t)
    if output.suffix == ".h5":
        _check_merge_memory([s.path for s in sets], output)
        with atomic_h5(output) as out:
            _copy_groups([ref for s in sets for ref in s._refs], out)
    else:  # a folder of trajectory files, renamed into place when all are written
        with atomic_dir(output, overwrite=overwrite) as tmp:
            for s in sets:
                for ref in s._refs:
                    if s.path.is_dir():
                        shutil.copyfile(ref.file, tmp / f"{ref.group}.h5")
                    else:
                        with atomic_h5(tmp / f"{ref.group}.h5") as out:
                            _copy_groups([ref], out)
    return len(names)


def _check_merge_memory(inputs, output: Path) -> None:
    """A merged ``.h5`` file is built in memory (:func:`dcdc.outputs.atomic_h5`): refuse
    inputs larger than half this machine's memory before copying any of them."""
    from ..scene.budget import physical_memory
    size = sum(f.stat().st_size for p in map(Path, inputs)
               for f in ([p] if p.is_file() else p.glob("*.h5")))
    mem = physical_memory()
    if mem and size > 0.5 * mem:
        raise DcdcError(f"merging {size / 2**30:.1f} GiB into the single file {output} needs "
                        f"more than half of this machine's {mem / 2**30:.1f} GiB of memory; "
                        f"merge into a directory (an output name without .h5) instead")


def _copy_groups(refs, out) -> None:
    """Copy trajectory groups into the open file ``out``. A merged file keeps the oldest
    format version of its sources (a version-1 group carries no checksums)."""
    versions = []
    for ref in refs:
        with _open(ref.file) as f:
            versions.append(int(f.attrs.get("format_version", 1)))
            f.copy(f[ref.group], out, name=ref.group)
    out.attrs["format"] = FORMAT
    out.attrs["format_version"] = min(versions, default=FORMAT_VERSION)
