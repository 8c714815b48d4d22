"""One ``dcdc generate`` job: what to simulate (:class:`Job`, the job lists of scenes and
random seeds), which simulator runs it, and :func:`run_job`, which simulates it and writes
``OUT/NAME.h5`` atomically. Used by the run in :mod:`.generate` and by the worker processes
of :mod:`.pool` (so neither imports the other)."""
from __future__ import annotations

import json
import os
import socket
import subprocess
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import click
import numpy as np

from ..errors import DcdcError, SimulationDiverged
from ..outputs import TMP_MARK, write_text
from ..scene.budget import check_run
from . import interrupt
from .dataset import write_trajectory


@dataclass
class Job:
    """One trajectory to generate."""

    name: str
    scene_text: str | None  # None for random jobs: drawn from ``random_cfg`` when run
    source: str  # "builtin:NAME", a file path, "random:SEED" or "family:NAME:SEED"
    dim: int
    resolution: float = 1.0
    seed: int = 0
    duration: float | None = None
    split: str = ""
    solver_overrides: dict | None = None
    random_cfg: dict | None = None
    max_particles: float | None = None  # budget override (None: dcdc.scene.budget default)

    def key(self) -> str:
        """What determines this trajectory: a resumed run must ask for the same thing."""
        import hashlib
        d = {"source": self.source, "dim": self.dim, "resolution": self.resolution,
             "duration": self.duration, "random_cfg": self.random_cfg,
             "solver_overrides": self.solver_overrides,
             "scene": None if self.random_cfg is not None else
             hashlib.sha1(self.scene_text.encode()).hexdigest()}
        return json.dumps(d, sort_keys=True, default=list)

    def text(self) -> str:
        if self.scene_text is None:
            from ..scene.random import RandomSceneConfig, random_scene_text
            self.scene_text = random_scene_text(self.seed, RandomSceneConfig(**self.random_cfg))
        return self.scene_text


# ------------------------------------------------------------------ stand-in simulator
class BallisticSimulator:
    """A stand-in for the SPH solver that moves particles ballistically (free fall). For
    testing the pipeline only (``--simulator ballistic``); ``DCDC_BALLISTIC_DELAY`` adds a
    sleep per frame so tests can kill a run mid-trajectory."""

    name = "ballistic (pipeline test stand-in, not physics)"

    def __init__(self, system, settings: dict | None = None):
        self.system = system
        self.time = 0.0
        self.stats = {"substeps": 1}
        self.settings = dict(settings or {})
        self.delay = float(os.environ.get("DCDC_BALLISTIC_DELAY", "0") or 0)

    def advance(self, dt: float) -> dict:
        s = self.system
        active = s.birth <= self.time
        s.x[active] += dt * s.v[active] + 0.5 * dt * dt * s.gravity
        s.v[active] += dt * s.gravity
        self.time += dt
        if self.delay:
            time.sleep(self.delay)
        return self.stats


def make_simulator(kind: str, system, solver_settings: dict):
    """(simulator, solver name, settings dict actually used)."""
    if kind == "ballistic":
        return BallisticSimulator(system, solver_settings), BallisticSimulator.name, dict(solver_settings)
    if kind != "sph":
        raise DcdcError(f"unknown simulator {kind!r} (sph or ballistic)")
    from ..sph import SPHConfig, Simulator
    cfg = SPHConfig.from_dict(solver_settings)
    sim = Simulator(system, cfg)
    return sim, f"dcdc.sph ({cfg.solver})", cfg.to_dict()


# ------------------------------------------------------------------ job list
def code_version() -> tuple[str, str]:
    from importlib.metadata import PackageNotFoundError, version
    try:
        v = version("dcdc")
    except PackageNotFoundError:
        v = "unknown"
    commit = ""
    try:
        here = Path(__file__).resolve().parent
        r = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True,
                           text=True, timeout=5)
        if r.returncode == 0:
            commit = r.stdout.strip()
            d = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--", str(here.parent)],
                               capture_output=True, text=True, timeout=5)
            if d.stdout.strip():
                commit += "+dirty"
    except (OSError, subprocess.SubprocessError):
        pass
    return v, commit


def scene_jobs(scenes, dim: int | None = None, resolution: float = 1.0,
               duration: float | None = None, split: str = "", solver_overrides=None,
               max_particles: float | None = None) -> list[Job]:
    """Jobs for built-in scene names / scene files, each checked now (scene, solver table,
    duration, emitters, particle and memory budget), before any worker starts."""
    from ..scene import builtin_names, builtin_text, get_scene
    from ..scene.budget import check as check_budget
    jobs = []
    for s in scenes:
        sc = get_scene(s)
        sc.check_solver()
        d = dim or sc.dim
        if d > sc.dim:
            raise DcdcError(f"scene {sc.name} is {sc.dim}-D; it has no {d}-D variant")
        run = check_run(sc, duration, sc.name)
        check_budget(sc.variant(d, resolution), sc.name, int(round(run / sc.frame_dt)) + 1, max_particles)
        text = builtin_text(s) if str(s) in builtin_names() else Path(s).read_text()
        name = f"{sc.name}_{d}d" + (f"_res{resolution:g}" if resolution != 1 else "")
        jobs.append(Job(name, text, f"builtin:{s}" if sc.builtin else str(Path(s).resolve()),
                        d, resolution, int(sc.data["seed"]), duration, split, solver_overrides))
    return jobs


def random_jobs(n: int, seed: int, cfg, duration: float | None = None, split: str = "",
                solver_overrides=None) -> list[Job]:
    """Jobs for ``n`` random scenes with seeds seed .. seed+n-1 (see dcdc.scene.random)."""
    cfg.check()
    return [Job(f"random_{s}_{cfg.dim}d", None, f"random:{s}", cfg.dim, 1.0, s, duration, split,
                solver_overrides, asdict(cfg)) for s in range(seed, seed + n)]


def family_jobs(family: str, n: int, seed: int, dim: int = 2, duration: float | None = None,
                split: str = "", solver_overrides=None) -> list[Job]:
    """Jobs for ``n`` scenes of a scene family (dcdc.scene.families) with seeds seed ..
    seed+n-1; ``family`` "all": scene i of family FAMILIES[i mod 8]. Seeds from
    SUITE_SEED0 (900 000) on belong to the generalisation suite: refused unless ``split``
    is "test"."""
    from ..scene.families import FAMILIES, SUITE_SEED0, family_scene_text
    if family != "all" and family not in FAMILIES:
        raise DcdcError(f"--family must be all or one of {', '.join(FAMILIES)} (got {family!r})")
    if n < 1:
        raise DcdcError(f"--random must be a number of scenes >= 1 (got {n})")
    if seed + n - 1 >= SUITE_SEED0 and split != "test":
        raise DcdcError(f"seeds {seed}..{seed + n - 1} reach into the generalisation suite's "
                        f"(>= {SUITE_SEED0}); training sets use seeds below {SUITE_SEED0} "
                        "(--split test to build suite scenes)")
    jobs = []
    for i, s in enumerate(range(seed, seed + n)):
        fam = FAMILIES[i % len(FAMILIES)] if family == "all" else family
        jobs.append(Job(f"{fam}_{s}_{dim}d", family_scene_text(fam, s, dim), f"family:{fam}:{s}",
                        dim, 1.0, s, duration, split, solver_overrides))
    return jobs


def parse_shard(shard: str | None) -> tuple[int, int]:
    if not shard:
        return 0, 1
    try:
        i, n = (int(p) for p in shard.split("/"))
    except ValueError:
        raise DcdcError(f"--shard must look like i/n, e.g. 0/4 (got {shard!r})") from None
    if not (n >= 1 and 0 <= i < n):
        raise DcdcError(f"--shard {shard}: need 0 <= i < n")
    return i, n


# ------------------------------------------------------------------ one trajectory
def set_threads(threads: int) -> None:
    """Numba/OpenMP thread count of this (worker) process."""
    os.environ["NUMBA_NUM_THREADS"] = str(threads)
    os.environ["OMP_NUM_THREADS"] = str(threads)
    try:
        import numba
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    except Exception:  # pragma: no cover - numba always present in this project
        pass


def run_job(job: Job, out_dir, simulator: str = "sph", progress=None,
            code_version=("", "")) -> dict:
    """Simulate one job and write ``out_dir/NAME.h5`` atomically. Returns a result record."""
    from ..scene import parse
    out_dir = Path(out_dir)
    t0 = time.time()
    final = out_dir / f"{job.name}.h5"
    for stale in out_dir.glob(f".{job.name}.h5{TMP_MARK}*"):
        stale.unlink(missing_ok=True)  # left by a killed run of this same job
    rec = {"name": job.name, "source": job.source, "dim": job.dim, "seed": job.seed}
    try:
        src_path = None if job.source.startswith(("builtin:", "random:", "family:")) else Path(job.source)
        scene = parse(job.text(), src_path.name if src_path else job.source, src_path)
        duration = check_run(scene, job.duration, job.name, warn=False)
        fdt = scene.frame_dt
        n_frames = int(round(duration / fdt))
        T = n_frames + 1
        with interrupt.at_once():  # building a large scene takes minutes without a frame
            system = scene.realize(dim=job.dim, resolution=job.resolution, frames=T,
                                   max_particles=job.max_particles)
            settings = {**scene.solver, **(job.solver_overrides or {})}
            sim, solver_name, settings_used = make_simulator(simulator, system, settings)
        xs = np.empty((T,) + system.x.shape, dtype=np.float32)
        vs = np.empty_like(xs)
        xs[0], vs[0] = system.x, system.v
        times = fdt * np.arange(T)
        substeps = 0
        for k in range(1, T):
            st = sim.advance(fdt) or getattr(sim, "stats", {})
            interrupt.check()  # Ctrl-C / SIGTERM stop the run here, between frames
            substeps += int(st.get("substeps", 0)) if isinstance(st, dict) else 0
            xs[k], vs[k] = sim.system.x, sim.system.v
            if progress:
                progress(1)
        wall = time.time() - t0
        attrs = {
            "name": job.name, "scene": scene.name, "scene_toml": job.text(), "source": job.source,
            "job_key": job.key(),
            "scene_dim": scene.dim, "resolution": job.resolution, "seed": job.seed,
            "split": job.split, "frame_dt": fdt, "duration": n_frames * fdt,
            "solver": solver_name, "solver_settings": json.dumps(settings_used, sort_keys=True),
            "solver_stats": json.dumps({"substeps_total": substeps,
                                        "last": _jsonable(getattr(sim, "stats", {}))}),
            "dcdc_version": code_version[0], "git_commit": code_version[1],
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "host": socket.gethostname(), "wall_time_s": wall,
        }
        write_trajectory(final, job.name, xs, vs, times, system, attrs)
        (out_dir / f"{job.name}.failed.json").unlink(missing_ok=True)
        rec.update(status="ok", frames=n_frames, particles=system.n_fluid, walls=system.n_wall,
                   wall_time_s=round(wall, 3), s_per_frame=round(wall / max(n_frames, 1), 4))
    except SimulationDiverged as e:
        rec.update(status="failed", error=str(e), wall_time_s=round(time.time() - t0, 3))
        _write_json(out_dir / f"{job.name}.failed.json", rec)
    return rec


def _check_same_job(path: Path, job: Job) -> None:
    import h5py
    with h5py.File(path, "r") as f:
        stored = f[job.name].attrs.get("job_key", None) if job.name in f else None
    if stored is not None and stored != job.key():
        raise DcdcError(f"{path} was generated with other settings than this run asks for "
                        f"(scene, options or solver overrides differ); use another --out directory")


def _jsonable(d):
    try:
        return json.loads(json.dumps(d, default=float))
    except (TypeError, ValueError):
        return {}


def _write_json(path: Path, obj) -> None:
    write_text(path, json.dumps(obj, indent=1, sort_keys=True))
