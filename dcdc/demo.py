"""``dcdc demo``: the main job of a fresh install.

Runs a built-in multiphase scene (default: the 2-D cocktail at twice its size, ~1 500
particles, four phases re-stratifying)
with the reference SPH solver, writes the trajectory (HDF5, dataset layout of
docs/datasets.md), a picture strip, an animation and the last frame as PLY for
ParaView/Blender, and prints whether the phases ended in the right order (heavy below);
if they did not, it exits non-zero with that reason. Beside SPH the shipped learned model
of the dimension (``dcdc2d`` / ``dcdc3d``; ``--model M`` for a checkpoint or another shipped
name, ``--model none`` for SPH alone) runs the same scene from the same start: its
trajectory, a strip of SPH above the model and an SPH | model animation (same camera, the
mean nearest-particle distance per panel, docs/render.md) and its numbers (steps before the
guard stopped it, ms per step, and against SPH per phase the centre-of-mass height, the
per-phase purity and the height distance, then the wall penetrations and the whole-rollout
error; the names and definitions of docs/evaluation.md) are added, with a verdict: the
model's stratification order (heavy below, by median height) and layers like SPH's
(:func:`verdict`); a model that fails it fails the demo.
``--no-contact`` runs the network alone, without the SPH solver's wall contact. The default model is skipped with a note
where the scene's particle radius or frame Δt is not the one it was trained for.
``--settle T`` starts the network from the SPH state at T s instead of the lattice start
(the 3-D networks burst from a deep lattice column, docs/models.md). The output folder is
checked before the simulation (an existing non-empty one only with ``--overwrite``, which
empties it) and each result is written as soon as it exists, the SPH trajectory first; the
report ``demo.txt`` comes last, so a folder without it holds an unfinished demo.

The outputs are named after the scene: a built-in by its job name (``cocktail_2d_res2.h5``),
a scene file by its file name (``--scene my.toml``: ``my_2d.h5``, ``my_2d.png``,
``my_2d_dcdc.h5``, ...), whatever name the file's ``name`` key holds. Before each run the demo
prints its size and an estimate of its time (:func:`estimate`).
"""
from __future__ import annotations

import math

import click
import numpy as np

from .errors import DcdcError, SimulationDiverged
from .evaluate import CONTACT_DEFAULT
from .particles import active_mask


DEMO_SCENE = "cocktail"
ORDER = "stratification order (heavy below)"  # docs/evaluation.md: order_ok, by median height
# Seconds per fluid particle of one SPH substep (DFSPH, default settings) and of one step of
# the shipped network (dcdc2d / dcdc3d, float32, wall contact on), by dimension: measured on
# the cocktail (2-D at resolution 2, 1 696 particles; 3-D, 8 048) on 2 cores of an AMD EPYC
# machine, 2 threads, load average 3.8-4.4 from other jobs (an idle machine is faster)
SPH_S_PER_PARTICLE_SUBSTEP = {2: 9.2e-6, 3: 1.3e-5}
NET_S_PER_PARTICLE_STEP = {2: 1.7e-5, 3: 2.2e-5}
DEMO_RESOLUTION = 2.0  # the 2-D cocktail section at scale 1 holds only ~400 particles
AUTO_MODEL = "auto"  # the shipped dcdc model of the scene's dimension


def default_resolution(scene: str, dim: int) -> float:
    """The demo's length scale: ×2 for the built-in cocktail in 2-D (its section at scale 1
    holds ~400 particles, too few to show layers), 1 otherwise (the 3-D cocktail at scale 1
    already has 8 048 particles; ×2 would be 8× that, hours of SPH on 2 cores)."""
    return DEMO_RESOLUTION if (scene == DEMO_SCENE and dim == 2) else 1.0


def output_name(scene: str, job_name: str, scene_name: str) -> str:
    """The demo's output name: ``job_name`` (``NAME_2d[_resS]``) with the scene's ``name``
    replaced by the file's name for a scene file (letters, digits, ``_`` and ``-`` kept)."""
    from pathlib import Path

    from .scene import builtin_names

    if scene in builtin_names():
        return job_name
    stem = "".join(c if c.isalnum() or c in "_-" else "_" for c in Path(scene).stem) or "scene"
    return stem + job_name[len(scene_name):]


def duration_text(seconds: float) -> str:
    """``seconds`` rounded for a reader: "about 40 s", "about 3 min", "about 2.5 h"."""
    if seconds < 90:
        return f"about {max(1, round(seconds, -1 if seconds >= 20 else 0)):g} s"
    if seconds < 90 * 60:
        return f"about {round(seconds / 60):g} min"
    return f"about {seconds / 3600:.1f} h"


def estimate(what: str, particles: int, work: int, seconds_per_particle: float,
             span: str) -> str:
    """The line printed before a run, e.g. "SPH: 1 696 particles, 15 s simulated (3 000
    substeps), about 50 s on 2 cores": time = ``particles`` × ``work`` (SPH substeps or
    network steps) × ``seconds_per_particle`` (:data:`SPH_S_PER_PARTICLE_SUBSTEP`,
    :data:`NET_S_PER_PARTICLE_STEP`)."""
    def n(v):
        return f"{v:,}".replace(",", " ")
    return (f"{what}: {n(particles)} particles, {span.format(n(work))}, "
            f"{duration_text(seconds_per_particle * particles * work)} on 2 cores")


def _active(traj, frame: int):
    return active_mask(traj.birth, getattr(traj, "death", None), float(traj.time[frame]))


def stratification(traj, frame: int) -> list[tuple[str, float, float]]:
    """(phase, rest density, median height) per phase at ``frame``, lightest phase first
    (:func:`dcdc.metrics.phase_heights` of the particles present; the median says where
    the bulk of a phase sits, a mean is dragged by the few droplets trapped under others)."""
    from .metrics import phase_heights
    h = phase_heights(traj.position[frame], traj.phase, len(traj.phases), "median",
                      active=_active(traj, frame))
    rows = [(p.name, p.density, float(h[k])) for k, p in enumerate(traj.phases) if np.isfinite(h[k])]
    return sorted(rows, key=lambda r: r[1])


def order_ok(traj, frame: int = -1) -> bool:
    """The demo's final check, :func:`dcdc.metrics.density_order_ok` (median heights):
    every phase lies below every lighter one."""
    from .metrics import density_order_ok
    return density_order_ok(traj.position[frame], traj.phase, [p.density for p in traj.phases],
                            "median", active=_active(traj, frame))


@click.command("demo")
@click.option("--scene", default=DEMO_SCENE, show_default=True, help="built-in name or scene file")
@click.option("--dim", type=click.Choice(["2", "3"]), default="2", show_default=True)
@click.option("--resolution", type=float, default=None,
              help="length scale of the scene at fixed particle size "
                   f"(default: {DEMO_RESOLUTION:g} for the built-in demo scene in 2-D, 1 otherwise)")
@click.option("--duration", type=float, default=None, help="seconds (default: the scene's)")
@click.option("--out", "out_dir", type=click.Path(), default="demo_out", show_default=True)
@click.option("--overwrite", is_flag=True, help="Replace an existing non-empty --out directory.")
@click.option("--max-particles", type=float, default=None,
              help="Particle budget (default 1e7 or $DCDC_MAX_PARTICLES).")
@click.option("--model", "model_path", default=AUTO_MODEL, show_default=True,
              help="learned model run beside SPH: a checkpoint, a shipped name (dcdc2d, "
                   "cconv3d, ...), 'auto' (the shipped dcdc model of --dim, skipped where the "
                   "scene's particle radius or frame dt is not its own) or 'none'")
@click.option("--contact/--no-contact", default=CONTACT_DEFAULT,
              help="with --model: the SPH solver's wall contact after each network step (a "
                   "safety net; its moves are reported) or the network alone [default: the "
                   "model's own: off for dcdc2d, on for dcdc3d]")
@click.option("--settle", type=float, default=None,
              help="with --model: hand the network the SPH state at SECONDS (e.g. 0.2) instead "
                   "of the lattice start; its file repeats the SPH frames before that")
def demo_command(scene, dim, resolution, duration, out_dir, overwrite, max_particles, model_path,
                 contact, settle):
    """Simulate a built-in multiphase scene with SPH and a shipped learned model, write both.

    Exits with status 2 when the phases do not end in density order (heavy below), in the
    SPH run or in the learned model's, or when the model's layers are not like SPH's."""
    from tqdm import tqdm

    from .data import interrupt
    from .data.dataset import Dataset
    from .data.jobs import code_version, run_job, scene_jobs
    from .outputs import check_dir, write_text
    from .render.export import write_points
    from .model.checkpoint import check_compatible, load_checkpoint
    from .render import animate, snapshot_strip
    from .scene import get_scene, parse
    from .sph.solver import rest_substep

    out = check_dir(out_dir, overwrite=overwrite)  # before any work: never after simulating
    net = None
    auto = model_path == AUTO_MODEL
    if auto:
        model_path = f"dcdc{dim}d"
    elif model_path == "none":
        model_path = None
    if model_path is not None:  # a wrong or mismatched model fails before the SPH run
        net, _ = load_checkpoint(model_path)
        check_compatible(net, dim=int(dim), what=f"demo scene {scene} in {dim}-D")
    elif settle is not None:
        raise DcdcError("--settle goes with a learned model (it hands the model the SPH "
                        "state), not with --model none")
    if resolution is None:
        resolution = default_resolution(scene, int(dim))
    job = scene_jobs([scene], dim=int(dim), resolution=resolution, duration=duration,
                     max_particles=max_particles)[0]
    job.max_particles = max_particles
    sc = parse(job.text(), job.source)
    job.name = output_name(scene, job.name, sc.name)
    n_frames = int(round((duration or sc.duration) / sc.frame_dt))
    start = 0
    if settle is not None:
        from .evaluate.start import settle_frames
        start = settle_frames(settle, sc.frame_dt)
        if start >= n_frames:
            raise DcdcError(f"--settle {settle:g} s is not before the end of the run "
                            f"({n_frames * sc.frame_dt:g} s)")
    neural = None
    if net is not None:  # the model must fit the scene's particles: checked before any work
        try:
            check_compatible(net, radius=float(sc.data["radius"]), frame_dt=sc.frame_dt,
                             what=f"scene {sc.name}")
        except DcdcError as e:
            if not auto:
                raise
            neural, net = f"no learned model: {e} (--model M runs another)", None
    system = get_scene(scene).realize(int(dim), resolution, max_particles=max_particles)
    substeps = n_frames * math.ceil(sc.frame_dt / rest_substep(sc.check_solver(), system) - 1e-9)
    click.echo(estimate("SPH", system.n_fluid, substeps, SPH_S_PER_PARTICLE_SUBSTEP[int(dim)],
                        f"{n_frames * sc.frame_dt:g} s simulated ({{}} substeps)"))
    click.echo(f"simulating {job.name} ({n_frames} frames of {sc.frame_dt} s) with the SPH solver")
    # each result is written as soon as it exists (an interrupted demo keeps the SPH run);
    # demo.txt, the report, comes last: a folder without it is an unfinished demo
    fresh_dir(out, overwrite)
    report: list[str] = []

    def wrote(name):
        click.echo(f"wrote {out / name}")

    with interrupt.handling():
        with tqdm(total=n_frames, unit="frame") as bar:
            rec = run_job(job, out, progress=bar.update, code_version=code_version())
        if rec["status"] != "ok":
            raise SimulationDiverged(f"{job.name}: {rec.get('error', 'failed')}")
        traj = Dataset(out)[job.name]
        names = [f"{job.name}.h5", f"{job.name}.png", f"{job.name}.gif", f"{job.name}_final.ply"]
        wrote(names[0])
        snapshot_strip(traj, out / names[1], title=f"{job.name}: dcdc SPH")
        wrote(names[1])
        interrupt.check()
        animate(traj, out / names[2])
        wrote(names[2])
        interrupt.check()
        write_points(out / names[3], traj.position[-1],
                     {"velocity": traj.velocity[-1], "phase": traj.phase, "density": traj.density})
        wrote(names[3])
        rows0, rows1 = stratification(traj, 0), stratification(traj, -1)
        ok = order_ok(traj)
        report += [f"{rec['particles']} fluid + {rec['walls']} wall particles, "
                   f"{rec['wall_time_s']:.1f} s wall for {n_frames * sc.frame_dt:.2f} s simulated",
                   f"{'phase':<12}{'density':>10}{'median height [m]: start':>26}{'end':>8}"]
        report += [f"{name:<12}{rho:>10g}{y0:>26.3f}{y1:>8.3f}"
                   for (name, rho, y0), (_, _, y1) in zip(rows0, rows1)]
        report.append(f"{ORDER}: {'yes' if ok else 'NO'}")
        neural_fail = None
        if net is not None:
            before = len(names)
            neural, neural_fail = _neural_beside(net, model_path, sc, traj, n_frames, out,
                                                 names, start, contact)
            for name in names[before:]:
                wrote(name)
        if neural is not None:
            report.append(neural)
        write_text(out / "demo.txt", "\n".join(report) + "\n")
    click.echo("\n".join(report))
    wrote("demo.txt")
    if not ok:
        heights = ", ".join(f"{n} {y:.3f} m" for n, _, y in rows1)
        raise DcdcError(f"{ORDER} failed: median heights (lightest first) {heights} "
                        "are not in density order, heavy below")
    if neural_fail is not None:
        raise DcdcError(f"the learned model {model_path} fails the demo's verdict against "
                        f"SPH: {neural_fail}")


def fresh_dir(out, overwrite: bool) -> None:
    """Make the output folder ``out`` (already checked by :func:`dcdc.outputs.check_dir`)
    empty: with ``overwrite`` an earlier demo's files are removed first, so no old file is
    mistaken for one of this run."""
    import shutil

    if overwrite and out.is_dir():
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)


def _neural_beside(net, model_path, sc, traj, n_frames: int, tmp, names: list,
                   start: int = 0, contact: bool | None = CONTACT_DEFAULT) -> tuple[str, str | None]:
    """Run ``net`` on the demo scene from the SPH run's frame ``start`` (0: the lattice
    start; later: the settled state, docs/models.md "The cocktail's start-up burst"); write
    its trajectory (the SPH frames before ``start`` first, so both files share frame times),
    a strip of SPH above the model and an SPH | model animation into ``tmp`` (names
    appended); returns (the report, None when the verdict passes or else why it fails).
    The whole-rollout error is averaged over the network's frames only; the final state
    is compared with SPH's at the same time by :func:`dcdc.evaluate.scores.compare_states`.
    The verdict (:func:`verdict`) asks the right order and layers like SPH's."""
    import imageio.v3 as iio
    from tqdm import tqdm

    from .data import interrupt
    from .data.dataset import Dataset
    from .evaluate.rollout import NeuralSimulator, run, write_rollout
    from .evaluate.scores import compare_states
    from .metrics import nearest_error
    from .render.figures import Figure, strip_frames
    from .render.frames import default_camera

    sim = NeuralSimulator(net, traj.system(start), time=float(traj.time[start]), contact=contact)
    since = f" from the SPH state at {traj.time[start]:g} s" if start else ""
    click.echo(estimate(f"learned model {model_path}", sim.system.n_fluid, n_frames - start,
                        NET_S_PER_PARTICLE_STEP[traj.dim], "{} steps"))
    click.echo(f"simulating {traj.name} with the learned model {model_path} ({net.name}){since}")
    with tqdm(total=n_frames - start, unit="step") as bar:
        ro = run(sim, n_frames - start, progress=bar.update, interrupt_check=interrupt.check)
    if start:
        ro = prefixed(ro, traj, start)
    name = f"{traj.name}_{net.name}"
    settled = {"settled_by_sph_s": float(traj.time[start])} if start else {}
    write_rollout(tmp / f"{name}.h5", name, ro, sim.system,
                  {"scene": sc.name, "frame_dt": sim.dt, "split": "rollout",
                   "solver": f"dcdc.neural ({net.name})", "model": str(model_path),
                   "wall_contact": int(sim.uses_contact), **settled},
                  steps_requested=n_frames - start)
    pred = Dataset(tmp / f"{name}.h5")[name]
    n = pred.n_frames
    err = [nearest_error(pred.position[f], traj.position[f]) for f in range(start, n)]
    fig = Figure.build([traj, pred], default_camera(traj, 360), None, 2, True)
    fig.labels = ["SPH", f"learned: {model_path}"]
    times = ",".join(f"{t:g}" for t in np.linspace(0.0, traj.time[n - 1], 4).round(2))
    with open(tmp / f"{name}_compare.png", "wb") as fh:
        iio.imwrite(fh, fig.strip(strip_frames(traj, times)), extension=".png")
    interrupt.check()
    fig.write_video(tmp / f"{name}_compare.gif", range(0, n, 2), 25, overwrite=True)
    names += [f"{name}.h5", f"{name}_compare.png", f"{name}_compare.gif"]
    mine, sph, com_rel = compare_states(pred.position[n - 1], traj.position[n - 1], traj,
                                        _active(traj, n - 1))
    stop = f"stopped by the guard: {ro.stopped}" if ro.stopped is not None else "ran through"
    moved = int(ro.contacts.sum()) if ro.contacts is not None else 0
    support = (f"wall contact on: {moved} particle moves back out of walls"
               if sim.uses_contact else "the network alone (no wall contact)")
    lines = [f"learned model {model_path}{since}: {ro.steps} of {n_frames - start} steps "
             f"({stop}), {ro.ms_per_step:.1f} ms per step, {support}",
             f"{'phase':<12}{'centre-of-mass height [m]':>30}{'per-phase purity':>18}"
             f"{'height distance':>17}",
             f"{'':<12}{'SPH':>12}{'learned':>9}{'error':>9}{'SPH':>8}{'learned':>10}"
             f"{'/ column':>17}"]
    for k, p in enumerate(traj.phases):
        if np.isfinite(com_rel[k]):
            lines.append(f"{p.name:<12}{sph['com_height'][k]:>12.3f}"
                         f"{mine['com_height'][k]:>9.3f}{com_rel[k]:>9.3f}"
                         f"{sph['purity_per_phase'][k]:>8.2f}{mine['purity_per_phase'][k]:>10.2f}"
                         f"{mine['height_w1_rel'][k]:>17.3f}")
    worst = float(np.nanmax(com_rel)) if np.isfinite(com_rel).any() else float("nan")
    lines.append(f"centre-of-mass height error {worst:.3f} (largest over phases), wall "
                 f"penetrations {int(ro.in_walls.max()) if len(ro.in_walls) else 0} (largest "
                 f"per step; {ro.entered_walls} particle(s) inside a wall at some step), "
                 f"whole-rollout error {1e3 * float(np.mean(err)):.1f} mm")
    why = verdict(mine, traj.phases)
    lines.append(f"verdict: {f'layers like SPH, {ORDER}: yes' if why is None else why}")
    return "\n".join(lines), why


def verdict(state: dict, phases) -> str | None:
    """None when a learned model's final state passes, else the reason: the stratification
    order (:data:`ORDER`, median heights) and layers like SPH's
    (:func:`dcdc.metrics.layers_like`: every phase's neighbour purity ≥ 0.9 × SPH's and its
    height distribution within 5 % of the column of SPH's; docs/evaluation.md, "Layers")."""
    if not state["order_ok"]:
        return f"{ORDER}: NO"
    if state["layers_ok"]:
        return None
    from .metrics import HEIGHT_FRACTION, PURITY_RATIO

    ratio, rel = np.asarray(state["purity_ratio"]), np.asarray(state["height_w1_rel"])
    mixed = [p.name for k, p in enumerate(phases)
             if np.isfinite(ratio[k]) and ratio[k] < PURITY_RATIO]
    off = [p.name for k, p in enumerate(phases) if np.isfinite(rel[k]) and rel[k] > HEIGHT_FRACTION]
    parts = ([f"more mixed than SPH (purity < {PURITY_RATIO:g} x SPH's) in {', '.join(mixed)}"]
             if mixed else []) \
        + ([f"heights off SPH's by > {100 * HEIGHT_FRACTION:g} % of the column in {', '.join(off)}"]
           if off else [])
    return "layers unlike SPH's: " + "; ".join(parts or ["no phase to compare"])


def prefixed(ro, traj, start: int):
    """``ro`` (a rollout from ``traj``'s frame ``start``) preceded by ``traj``'s frames
    0..start−1, so that frame k of both is the same time (no wall counts for SPH frames)."""
    import dataclasses
    zeros = np.zeros(start, dtype=np.int64)
    return dataclasses.replace(
        ro, position=np.concatenate([traj.position[:start].astype(ro.position.dtype), ro.position]),
        velocity=np.concatenate([traj.velocity[:start].astype(ro.velocity.dtype), ro.velocity]),
        time=np.concatenate([traj.time[:start], ro.time]),
        in_walls=np.concatenate([zeros, ro.in_walls]),
        contacts=None if ro.contacts is None else np.concatenate([zeros, ro.contacts]),
        sph_frames=start)
