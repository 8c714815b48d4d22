"""``dcdc benchmark table1``: the paper's Table 1 (§4.4, "time consumption per simulation
step") measured here, in one run, with the speed-up it argues for.

For each showcase (cocktail, hourglass, canyon; 2-D with the shipped 2-D model, 3-D when a
3-D model is given) the same initial state is advanced

* by the learned simulator (:class:`~dcdc.evaluate.rollout.NeuralSimulator`, with the
  model's own wall-contact default, as ``dcdc simulate`` runs it; neighbour searches
  included): ``--seconds`` of simulated time in steps of the model's
  Δt (0.02 s); the first step (kernel compilation) is not timed; ms per step is the median;
* by the SPH solver that made the training data (:class:`dcdc.sph.Simulator` with the
  scene's ``[solver]`` settings, CFL-adaptive substeps): the same simulated time after one
  untimed warm-up frame; mean substep Δt and ms per substep.

Both report wall seconds per simulated second; the speed-up is their ratio. The paper's own
figures (its GPU, the IMM mixture solver as baseline) are printed beside ours: the hardware,
the resolution and the baseline differ, so only the shape of the comparison carries over.
"""
from __future__ import annotations

import json
import statistics
import time

import click

from ..errors import DcdcError

SHOWCASES = ("cocktail", "hourglass", "canyon")
# paper Table 1: seconds per step, ours vs the IMM mixture solver [10] (their hardware)
PAPER = {"hourglass": (0.0026, 0.0031), "cocktail": (0.0058, 0.0064), "canyon": (0.0099, 0.0112)}


def neural_cost(model, system, seconds: float, device: str = "cpu") -> dict:
    """Median ms per network step over ``seconds`` of simulated time (first step untimed)."""
    from .rollout import Guard, NeuralSimulator

    sim = NeuralSimulator(model, system, guard=Guard(max_in_walls=1.0, check_domain=False),
                          device=device, contact=None)
    n = max(2, int(round(seconds / sim.dt)) + 1)
    for _ in range(n):
        sim.step()
    ms = statistics.median(sim.step_ms[1:])
    return {"steps": n - 1, "dt": sim.dt, "ms_per_step": ms,
            "s_per_simulated_s": ms / 1e3 / sim.dt, "contact": bool(sim.uses_contact),
            "contacts": int(sim.totals["contacts"])}


def sph_cost(system, solver: dict, seconds: float, frame_dt: float) -> dict:
    """SPH substeps and wall time over ``seconds`` after one untimed warm-up frame."""
    from ..sph import SPHConfig, Simulator

    sim = Simulator(system, SPHConfig.from_dict(solver))
    sim.advance(frame_dt)  # compiles the kernels
    frames = max(1, int(round(seconds / frame_dt)))
    sub, t0 = 0, time.perf_counter()
    for _ in range(frames):
        sub += sim.advance(frame_dt)["substeps"]
    wall = time.perf_counter() - t0
    sim_s = frames * frame_dt
    return {"simulated_s": sim_s, "substeps": sub, "mean_substep_s": sim_s / sub,
            "ms_per_substep": 1e3 * wall / sub, "s_per_simulated_s": wall / sim_s}


def measure(scene: str, dim: int, model, seconds: float, device: str = "cpu") -> dict:
    """One row of the table: particles, neural and SPH cost, speed-up."""
    from ..scene import get_scene

    sc = get_scene(scene)
    n_frames = int(round(seconds / sc.frame_dt)) + 3
    system = sc.realize(dim=dim, frames=n_frames)
    nn = neural_cost(model, system.copy(), seconds, device)
    sph = sph_cost(system.copy(), sc.solver, seconds, sc.frame_dt)
    row = {"scene": scene, "dim": dim, "fluid_particles": int(system.n_fluid),
           "wall_particles": int(system.n_wall), "phases": len(system.phases),
           "model": model.name, "neural": nn, "sph": sph,
           "speedup": sph["s_per_simulated_s"] / nn["s_per_simulated_s"],
           "step_ratio": nn["dt"] / sph["mean_substep_s"]}
    if scene in PAPER:
        row["paper_s_per_step"] = {"ours": PAPER[scene][0], "imm_mixture": PAPER[scene][1]}
    return row


def format_table(rows: list[dict]) -> str:
    head = ("| scene | particles (fluid + wall) | neural ms/step | SPH mean substep | SPH ms/substep "
            "| neural s per sim. s | SPH s per sim. s | speed-up | paper: ours / IMM ms/step |")
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        nn, sph = r["neural"], r["sph"]
        paper = r.get("paper_s_per_step")
        p = f"{1e3 * paper['ours']:.1f} / {1e3 * paper['imm_mixture']:.1f}" if paper else "-"
        lines.append(
            f"| {r['scene']} {r['dim']}-D ({r['model']}, "
            f"{'contact' if nn.get('contact', True) else 'alone'}) | {r['fluid_particles']} + "
            f"{r['wall_particles']} | {nn['ms_per_step']:.1f} | {1e3 * sph['mean_substep_s']:.2f} ms "
            f"| {sph['ms_per_substep']:.1f} | {nn['s_per_simulated_s']:.2f} "
            f"| {sph['s_per_simulated_s']:.2f} | {r['speedup']:.1f}× | {p} |")
    return "\n".join(lines)


@click.command("table1")
@click.option("--model", "model2d", default="dcdc2d", show_default=True,
              help="the 2-D model (a checkpoint or a shipped name)")
@click.option("--model3d", default=None,
              help="a 3-D model: adds the 3-D showcases at their default resolution")
@click.option("--scene", "scenes", multiple=True, help=f"default: {', '.join(SHOWCASES)}")
@click.option("--seconds", type=float, default=1.0, show_default=True,
              help="simulated seconds per measurement (both simulators)")
@click.option("--seconds3d", type=float, default=0.2, show_default=True,
              help="the same for the 3-D showcases (SPH in 3-D is slow here)")
@click.option("--device", default="cpu", show_default=True, help="where the network runs")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None)
@click.option("--note", default="", help="free text stored in the JSON (e.g. machine load)")
def table1_command(model2d, model3d, scenes, seconds, seconds3d, device, json_path, note):
    """The paper's Table 1 here: neural step vs SPH per showcase, and the speed-up."""
    import torch

    from ..model.benchmark import machine_info
    from ..model.checkpoint import load_checkpoint
    from ..outputs import check_file, write_text

    if not (seconds > 0 and seconds3d > 0):
        raise DcdcError("--seconds and --seconds3d must be > 0")
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise DcdcError(f"--device {device}: no CUDA device here (torch {torch.__version__})")
    if json_path:
        check_file(json_path, overwrite=True)
    jobs = [(s, 2) for s in (scenes or SHOWCASES)]
    if model3d:
        jobs += [(s, 3) for s in (scenes or SHOWCASES)]
    nets = {2: load_checkpoint(model2d, dim=2, device=device)[0]}
    if model3d:
        nets[3] = load_checkpoint(model3d, dim=3, device=device)[0]
    rows = []
    with torch.no_grad():
        for s, d in jobs:
            click.echo(f"{s} {d}-D ...", err=True)
            rows.append(measure(s, d, nets[d], seconds if d == 2 else seconds3d, device))
    click.echo(format_table(rows))
    if json_path:
        doc = {"machine": machine_info(), "device": device, "note": note,
               "models": {"2d": model2d, "3d": model3d}, "rows": rows}
        write_text(json_path, json.dumps(doc, indent=1))
        click.echo(f"wrote {json_path}")
