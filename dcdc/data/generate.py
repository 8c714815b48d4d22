"""``dcdc generate``: run the SPH solver on scenes and write a trajectory dataset.

Design (resumable, shardable, never half-written):
- The job list is deterministic: the scenes in the order given (each in the requested
  dimension), or ``--random N --seed S`` = random scenes with seeds S, S+1, ..., S+N-1
  (with ``--family NAME|all``: scenes of the scene families, dcdc.scene.families).
- ``--shard i/n`` keeps jobs j with j mod n == i, so n machines (or batch-array tasks)
  split the work without talking to each other; merge the outputs with
  ``dcdc dataset merge``.
- Each trajectory becomes its own file ``OUT/NAME.h5``: written to ``.NAME.h5.tmp-PID``,
  flushed, fsynced and renamed (atomic on POSIX), with a ``complete`` attribute set last.
  A killed run leaves at most a temporary file, which readers ignore and the next run
  deletes. Re-running the same command skips every finished trajectory (and, unless
  ``--retry-failed``, every diverged one, recorded as ``NAME.failed.json``).
- ``OUT/dataset.json`` (an index: command, settings, trajectories, timing) is rewritten
  atomically at the end of each run; readers never depend on it.
- ``--workers W`` runs W scenes at once in spawned processes (:mod:`.pool`: one job at a
  time per worker, workers die with their parent); each sets its numba thread count to
  max(1, cores // W) so the machine is not oversubscribed.
- Ctrl-C / SIGTERM stop the run between solver steps, or at once while a scene is being
  built (:mod:`.interrupt`): finished trajectories stay, in-flight ones are discarded,
  re-running resumes.
- Before any work: the output directory is checked (:mod:`dcdc.outputs`), every scene's
  particle and memory budget (:mod:`dcdc.scene.budget`) and the run's duration.
- Every frame a trajectory holds is checked for coincident particles
  (:data:`COINCIDENT_PARTICLES` particles each closer than :data:`COINCIDENT` particle
  radii to another for :data:`COINCIDENT_FRAMES` consecutive frames, :func:`first_coincident`); such a trajectory is not kept: its file is
  removed and it is recorded as failed (``NAME.failed.json``, with the frame and the pair in
  a one-line reason), like one that diverged, so no dataset carries particles stuck on top
  of each other.
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import click
import numpy as np

from ..errors import DcdcError
from ..outputs import check_dir
from ..particles import active_mask
from ..scene.schema import SEED_MAX
from . import interrupt
from .dataset import is_complete, removed_count
from ..scene.budget import check_duration
from .jobs import (Job, _check_same_job, _write_json, code_version, parse_shard,
                   family_jobs, random_jobs, run_job, scene_jobs)

COINCIDENT = 0.05
"""[particle radii] Two active particles closer than this sit practically on top of each
other (lattice neighbours are 2 r apart): the pressure force, whose kernel gradient
vanishes as the distance does, cannot part them, and a network started from such a frame
has no length scale to part them either (one moved 46 particles by up to 61 m in one step)."""
COINCIDENT_FRAMES = 10
"""Consecutive frames (0.2 s at the usual frame interval) a particle must stay that close to
another to count: where the pressure is zero (spray, a thinned-out sheet) pairs pass within
0.05 r for a frame or a few in many trajectories and part again."""
COINCIDENT_PARTICLES = 3
"""How many particles must be stuck at once: a collapse piles particles onto a few points
(33 particles at three points in a wall's corner); a lone jammed pair is left alone."""


def first_coincident(positions, radius: float, times=None, birth=None, death=None,
                     limit: float = COINCIDENT, frames: int = COINCIDENT_FRAMES,
                     particles: int = COINCIDENT_PARTICLES):
    """The first coincident particles in ``positions`` [T, N, d] (anything that slices by
    frame, e.g. an HDF5 dataset, read one frame at a time): ``particles`` particles at once
    whose nearest active neighbour has been closer than ``limit`` · ``radius`` in ``frames``
    consecutive frames. Returns ``(k, i, j, distance)``: the first frame k of the first such
    particle's streak and its closest pair there, or None. With ``times`` and ``birth``
    (``death``: None = none removed) only the particles active in each frame are compared (:func:`dcdc.particles.active_mask`: unborn ones wait
    at their nozzle, removed ones stay where they left)."""
    from scipy.spatial import cKDTree

    streak, first = None, {}
    for k in range(len(positions)):
        x = np.asarray(positions[k], dtype=np.float64)
        if streak is None:
            streak = np.zeros(len(x), dtype=np.int64)
        idx = np.arange(len(x))
        if times is not None and birth is not None:
            idx = np.flatnonzero(active_mask(birth, death, float(times[k])))
        close = np.zeros(len(x), dtype=bool)
        if len(idx) >= 2:
            d, nn = cKDTree(x[idx]).query(x[idx], k=2)
            hit = d[:, 1] < limit * radius
            close[idx[hit]] = True
            for a in np.flatnonzero(hit):
                i = int(idx[a])
                if streak[i] == 0:  # the pair where this particle's streak starts
                    first[i] = (k, *sorted((i, int(idx[nn[a, 1]]))), float(d[a, 1]))
        streak = np.where(close, streak + 1, 0)
        done = np.flatnonzero(streak >= frames)
        if len(done) >= particles:
            return first[int(done[0])]
    return None


def check_written(out_dir, rec: dict) -> dict:
    """Check every frame of the trajectory just written (``rec`` of
    :func:`~dcdc.data.jobs.run_job` with status "ok") for coincident particles; when it has
    some, its file is removed and it is recorded as failed (``NAME.failed.json``, the reason
    in one line). Returns the record, updated."""
    import h5py

    path = Path(out_dir) / f"{rec['name']}.h5"
    with h5py.File(path, "r") as f:
        g = f[rec["name"]]
        r = float(g.attrs["radius"])
        times = g["time"][:]
        hit = first_coincident(g["position"], r, times, g["birth"][:],
                               g["death"][:] if "death" in g else None)
    if hit is None:
        return rec
    k, i, j, dist = hit
    path.unlink(missing_ok=True)
    rec = dict(rec, status="failed",
               error=f"coincident particles: {i} and {j} are {dist / r:.3g} r apart at "
                     f"t = {times[k]:.4f} s (frame {k}), and {COINCIDENT_PARTICLES} or more "
                     f"particles stay within {COINCIDENT:g} r of another for "
                     f"{COINCIDENT_FRAMES} frames")
    _write_json(Path(out_dir) / f"{rec['name']}.failed.json", rec)
    return rec


# ------------------------------------------------------------------ the run
def generate(jobs: list[Job], out_dir, workers: int = 1, shard: str | None = None,
             simulator: str = "sph", retry_failed: bool = False, progress: bool = True,
             command: str = "", frames_of=None) -> dict:
    """Generate every job of this shard not yet finished in ``out_dir``. Returns a summary
    (counts of done / skipped / failed, particles removed at the domain's edge, timing). Jobs
    that diverge are recorded, the rest go on."""
    out_dir = check_dir(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [j.name for j in jobs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DcdcError(f"two jobs would write the same trajectory: {', '.join(dup)}")
    i, n = parse_shard(shard)
    mine = [j for k, j in enumerate(jobs) if k % n == i]
    todo, skipped = [], []
    for j in mine:
        if is_complete(out_dir / f"{j.name}.h5"):
            _check_same_job(out_dir / f"{j.name}.h5", j)
            skipped.append(j.name)
        elif (out_dir / f"{j.name}.failed.json").exists() and not retry_failed:
            skipped.append(j.name)
        else:
            todo.append(j)
    version = code_version()

    def frames(j):
        if frames_of:
            return frames_of(j)
        if j.duration is not None:
            return int(round(j.duration / 0.02))
        if j.scene_text is None:  # random scene, drawn later: 2-3 s, ~125 frames
            return int(round((j.random_cfg.get("duration") or 2.5) / 0.02))
        from ..scene.format import tomllib  # tomli on Python 3.10
        d = tomllib.loads(j.scene_text)
        return int(round(d.get("duration", 2.0) / d.get("frame_dt", 0.02)))
    total = sum(frames(j) for j in todo)
    from tqdm import tqdm
    bar = tqdm(total=total, unit="frame", disable=not progress, dynamic_ncols=True,
               desc=f"{len(todo)} trajectories" + (f" (shard {i}/{n})" if n > 1 else ""))
    results = []
    t0 = time.time()
    workers = max(1, min(workers, len(todo))) if todo else 1

    def finished(rec):
        if rec["status"] == "ok":
            rec = check_written(out_dir, rec)
        if rec["status"] == "ok":  # particles that left the domain (solver on_escape = "remove")
            rec["removed"] = removed_count(out_dir / f"{rec['name']}.h5", rec["name"])
        results.append(rec)
        bar.set_postfix_str(f"done {len(results)}/{len(todo)}")
    try:
        with interrupt.handling():
            if workers == 1:
                for j in todo:
                    interrupt.check()
                    finished(run_job(j, out_dir, simulator, bar.update, version))
            else:
                from .pool import run_pool
                threads = max(1, (os.cpu_count() or 1) // workers)
                run_pool(todo, workers, threads, out_dir, simulator, version, bar.update, finished)
    except interrupt.Interrupted as e:
        bar.close()
        ok = sum(r["status"] == "ok" for r in results)
        raise interrupt.Interrupted(e.signum, f"{e}: {ok} trajectories written this run, the ones "
                                    "in flight discarded; re-run the same command to resume") from None
    finally:
        bar.close()
    summary = {
        "command": command, "out": str(out_dir), "shard": f"{i}/{n}", "workers": workers,
        "simulator": simulator, "jobs_in_shard": len(mine), "skipped": len(skipped),
        "done": sum(r["status"] == "ok" for r in results),
        "failed": [r for r in results if r["status"] != "ok"],
        "removed": sum(r.get("removed", 0) for r in results),
        "wall_time_s": round(time.time() - t0, 2), "results": results,
    }
    _write_index(out_dir, summary)
    return summary


def _write_index(out_dir: Path, summary: dict) -> None:
    """dataset.json: finished trajectories on disk plus a log of the runs (informative)."""
    idx_path = out_dir / "dataset.json"
    try:
        idx = json.loads(idx_path.read_text()) if idx_path.exists() else {}
    except (OSError, ValueError):
        idx = {}
    runs = idx.get("runs", [])
    runs.append({k: v for k, v in summary.items() if k != "results"}
                | {"finished": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                   "per_trajectory": [{k: r.get(k) for k in ("name", "status", "particles", "removed",
                                                             "frames", "wall_time_s", "s_per_frame")}
                                      for r in summary["results"]]})
    done = sorted(p.name[:-3] for p in out_dir.glob("*.h5") if not p.name.startswith("."))
    _write_json(idx_path, {"format": "dcdc-dataset", "trajectories": done, "runs": runs[-50:]})


# ------------------------------------------------------------------ CLI
@click.command("generate")
@click.argument("scenes", nargs=-1)
@click.option("-o", "--out", "out", type=click.Path(file_okay=False), required=True,
              help="Dataset directory (one NAME.h5 per trajectory).")
@click.option("--random", "n_random", type=int, default=0, help="Generate N random scenes instead.")
@click.option("--family", default=None, metavar="NAME|all",
              help="With --random N: scenes of a scene family (dcdc.scene.families; all = the "
                   "families in turn); seeds >= 900000 are the suite's (--split test only); "
                   "--max-ratio, --min-ratio, --density-range do not apply.")
@click.option("--seed", type=click.IntRange(0, SEED_MAX), default=0, show_default=True,
              help="First random-scene seed.")
@click.option("--dim", type=click.IntRange(2, 3), default=None,
              help="Dimension (default: the scene's; 2 = cross-section of a 3-D scene; random: 2).")
@click.option("--resolution", type=float, default=1.0, show_default=True,
              help="Scene length scale at fixed particle radius (built-in / file scenes).")
@click.option("--max-ratio", type=float, default=10.0, show_default=True, help="Random scenes: max density ratio.")
@click.option("--min-ratio", type=float, default=1.0, show_default=True, help="Random scenes: min density ratio.")
@click.option("--density-range", type=(float, float), default=(500.0, 5000.0), show_default=True)
@click.option("--tension", type=float, default=0.0, show_default=True,
              help="Random scenes: interfacial tension σ [N/m] between every pair of phases "
                   "(the solver's default model; the family scenes use 20).")
@click.option("--duration", type=float, default=None, help="Override every scene's duration [s].")
@click.option("--split", default="", help="Label stored with each trajectory (train/valid/test).")
@click.option("--workers", type=int, default=1, show_default=True, help="Scenes simulated in parallel.")
@click.option("--shard", default=None, help="i/n: do only jobs j with j mod n == i.")
@click.option("--sph", "sph_set", multiple=True, metavar="KEY=VALUE",
              help="Override a solver setting (repeatable), e.g. --sph cfl=0.3.")
@click.option("--simulator", type=click.Choice(["sph", "ballistic"]), default="sph", show_default=True,
              help="ballistic = free-fall stand-in for testing the pipeline only.")
@click.option("--retry-failed", is_flag=True, help="Re-run trajectories that diverged before.")
@click.option("--max-particles", type=float, default=None,
              help="Particle budget per scene (default 1e7 or $DCDC_MAX_PARTICLES).")
@click.option("--no-progress", is_flag=True)
def generate_command(scenes, out, n_random, family, seed, dim, resolution, max_ratio, min_ratio,
                     density_range, tension, duration, split, workers, shard, sph_set, simulator,
                     retry_failed, max_particles, no_progress):
    """Simulate SCENES (built-in names or .toml files) or --random N scenes into a dataset.

    Re-running the same command resumes: finished trajectories are skipped.
    """
    check_dir(out)
    check_duration(duration)
    if n_random < 0:
        raise DcdcError(f"--random must be a number of scenes >= 1 (got {n_random})")
    overrides = {}
    for kv in sph_set:
        if "=" not in kv:
            raise DcdcError(f"--sph expects KEY=VALUE (got {kv!r})")
        k, v = kv.split("=", 1)
        try:
            overrides[k] = json.loads(v)
        except ValueError:
            overrides[k] = v
    if workers < 1:
        raise DcdcError("--workers must be >= 1")
    if bool(scenes) == bool(n_random):
        raise DcdcError("give scene names/files or --random N (not both, not neither)")
    if tension and not n_random or tension and family is not None:
        raise DcdcError("--tension applies to --random scenes only (the family scenes have "
                        "20 N/m; a scene file sets [solver.interfacial_tension])")
    if family is not None and not n_random:
        raise DcdcError("--family needs --random N (the number of scenes)")
    if family is not None:
        jobs = family_jobs(family, n_random, seed, dim or 2, duration, split, overrides or None)
    elif n_random:
        from ..scene.random import RandomSceneConfig
        cfg = RandomSceneConfig(dim=dim or 2, max_ratio=max_ratio, min_ratio=min_ratio,
                                density_range=tuple(density_range), tension=tension)
        cfg.check()
        jobs = random_jobs(n_random, seed, cfg, duration, split, overrides or None)
    else:
        jobs = scene_jobs(scenes, dim, resolution, duration, split, overrides or None, max_particles)
    for j in jobs:
        j.max_particles = max_particles
    if overrides:  # SPH settings: checked whichever simulator runs (ballistic stores them)
        from ..sph import SPHConfig
        SPHConfig.from_dict(overrides)  # fail fast on a typo
    summary = generate(jobs, out, workers, shard, simulator, retry_failed, not no_progress,
                       command=" ".join(["dcdc", "generate"] + sys.argv[2:]))
    ok = [r for r in summary["results"] if r["status"] == "ok"]
    rate = (f", {np.mean([r['wall_time_s'] for r in ok]):.1f} s per trajectory "
            f"({np.mean([r['s_per_frame'] for r in ok]):.3f} s/frame)") if ok else ""
    removed = (f", {summary['removed']} particle(s) removed after leaving the domain"
               if summary["removed"] else "")
    click.echo(f"{summary['done']} written, {summary['skipped']} already done, "
               f"{len(summary['failed'])} failed{removed}, in {summary['wall_time_s']:.1f} s{rate} "
               f"-> {out}")
    for r in summary["failed"]:
        click.echo(f"  failed {r['name']}: {r.get('error')}", err=True)
    if summary["failed"]:
        raise DcdcError(f"{len(summary['failed'])} trajectory(ies) diverged or held coincident "
                        f"particles (recorded as NAME.failed.json; --retry-failed re-runs them)")
