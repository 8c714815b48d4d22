"""``dcdc simulate`` (a neural rollout written as a trajectory) and ``dcdc evaluate``
(models against SPH ground truth). Thin layers over :mod:`.rollout` and :mod:`.scores`."""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import click

from ..errors import DcdcError
from . import CONTACT_DEFAULT
from .start import (check_start_frame, settle_frames, settle_with_sph, start_from_dataset,
                    start_from_scene)


@click.command("simulate")
@click.option("--model", "model_path", required=True, type=click.Path(dir_okay=False),
              help="a dcdc checkpoint (dcdc train, dcdc model import-dlf)")
@click.option("--scene", default=None,
              help="built-in name, scene file (.toml) or DeepLagrangianFluids scene (.json)")
@click.option("--dim", type=click.Choice(["2", "3"]), default=None,
              help="with --scene (default: the model's for a 3-D scene)")
@click.option("--resolution", type=float, default=1.0, show_default=True,
              help="with --scene: length scale at fixed particle size")
@click.option("--dataset", default=None, help="start from a ground-truth trajectory of this dataset")
@click.option("--trajectory", default=None, help="with --dataset: the trajectory's name")
@click.option("--start-frame", type=int, default=0, show_default=True, help="with --dataset")
@click.option("--steps", type=int, default=None,
              help="network steps (default: the scene's duration / the trajectory's frames)")
@click.option("--max-speed", type=float, default=50.0, show_default=True,
              help="guard: a faster particle stops the rollout [m/s]")
@click.option("--max-in-walls", type=float, default=0.01, show_default=True,
              help="guard: the largest fraction of particles allowed inside walls")
@click.option("--contact/--no-contact", default=CONTACT_DEFAULT,
              help="move particles that reach a wall's solid back to its surface after each "
                   "step (the SPH solver's wall contact); --no-contact: the network alone "
                   "[default: the model's own: off for dcdc2d and cconv2d, on for the others]")
@click.option("--device", default="cpu", show_default=True)
@click.option("--bf16", is_flag=True,
              help="the convolutions' GEMMs in bf16 (CPU; faster only where the CPU has bf16 "
                   "instructions, e.g. AMX; docs/speed.md)")
@click.option("--max-particles", type=float, default=None, help="raise the scene's particle budget")
@click.option("--settle", type=float, default=None,
              help="with --scene: run the scene's SPH solver for the first SECONDS (e.g. 0.2) "
                   "and start the network from that settled state (the file starts there)")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="rollout .h5 file")
@click.option("--overwrite", is_flag=True, help="replace an existing --out file")
def simulate_command(model_path, scene, dim, resolution, dataset, trajectory, start_frame, steps,
                     max_speed, max_in_walls, contact, device, bf16, max_particles, settle, out,
                     overwrite):
    """Roll out a learned model and write the trajectory (dataset HDF5 layout)."""
    from tqdm import tqdm

    from ..data import interrupt
    from ..data.jobs import code_version
    from ..outputs import check_file
    from ..model.checkpoint import check_compatible, load_checkpoint
    from .rollout import Guard, NeuralSimulator, run, write_rollout

    if (scene is None) == (dataset is None):
        raise DcdcError("give exactly one of --scene or --dataset")
    if dataset is not None and trajectory is None:
        raise DcdcError("--dataset needs --trajectory NAME (dcdc dataset info lists them)")
    if dataset is None and (trajectory is not None or start_frame):
        raise DcdcError("--trajectory and --start-frame need --dataset")
    if scene is None and dim is not None:
        raise DcdcError("--dim goes with --scene (a trajectory has its own dimension)")
    if steps is not None and steps < 1:
        raise DcdcError(f"--steps must be >= 1 (got {steps})")
    if settle is not None and scene is None:
        raise DcdcError("--settle goes with --scene (a trajectory's frames are already settled: "
                        "use --start-frame)")
    if settle is not None and not settle > 0:
        raise DcdcError(f"--settle must be > 0 seconds (got {settle:g})")
    if bf16 and device != "cpu":
        raise DcdcError("--bf16 is for the CPU kernels; leave it out with --device "
                        f"{device}")
    out = check_file(out, overwrite)
    guard = Guard(max_speed=max_speed, max_in_walls=max_in_walls)
    model, ck = load_checkpoint(model_path, device=device)
    if bf16:
        import torch
        model.set_backend("auto", torch.bfloat16)
    t_start = 0.0
    if settle is not None:  # a bad value fails before any work
        if scene.endswith(".json"):
            raise DcdcError("--settle needs a dcdc scene (.toml or built-in): a "
                            "DeepLagrangianFluids scene has no [solver] table")
        frames = settle_frames(settle, model.cfg.frame_dt)
    if scene is not None:
        system, n, attrs = start_from_scene(scene, dim, resolution, model, steps, max_particles)
        if settle is not None:
            with interrupt.handling(), tqdm(total=frames, unit="SPH frame",
                                            desc="settling (SPH)") as bar:
                t_start = settle_with_sph(system, scene, frames, model.cfg.frame_dt, bar.update)
            if steps is None:  # the scene's duration in all
                n = max(1, n - frames)
            attrs["settled_by_sph_s"] = t_start
    else:
        system, t_start, n, attrs, fdt = start_from_dataset(dataset, trajectory, start_frame, steps)
        check_compatible(model, frame_dt=fdt, what=f"trajectory {trajectory}")
    sim = NeuralSimulator(model, system, guard=guard, time=t_start, device=device,
                          contact=contact)
    name = f"{attrs['scene']}_{system.dim}d" if dataset is None else trajectory
    click.echo(f"{model.name} ({model_path}) on {name}: {system.n_fluid} fluid + "
               f"{system.n_wall} wall particles, {n} steps of {sim.dt:g} s")
    t0 = time.time()
    with interrupt.handling(), tqdm(total=n, unit="step") as bar:
        ro = run(sim, n, progress=bar.update, interrupt_check=interrupt.check)
    version, commit = code_version()
    meta = {**attrs, "name": name, "frame_dt": sim.dt, "split": "rollout",
            "solver": f"dcdc.neural ({model.name})",
            "solver_settings": json.dumps(model.config(), sort_keys=True),
            "model": str(model_path), "model_digest": str(ck.get("digest", "")),
            "wall_contact": int(sim.uses_contact), "gemm_precision": "bf16" if bf16 else "float32",
            "dcdc_version": version, "git_commit": commit,
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "wall_time_s": time.time() - t0}
    write_rollout(out, name, ro, sim.system, meta, steps_requested=n)
    walls = int(ro.in_walls.max()) if len(ro.in_walls) else 0
    moved = (f", wall contact on: {int(ro.contacts.sum())} particle move(s) out of walls"
             if sim.uses_contact else ", the network alone (no wall contact)")
    partial = " (PARTIAL: stopped by the guard, recorded in the file)" if ro.stopped else ""
    click.echo(f"wrote {out}: {ro.steps} of {n} steps{partial}, {ro.ms_per_step:.1f} ms per "
               f"step, at most {walls} particle(s) inside walls at a time, "
               f"{ro.entered_walls} in all{moved}")
    if ro.stopped is not None:
        raise ro.stopped


def _labels(paths) -> list[str]:
    """Column labels for models: the file stem, made unique."""
    out = []
    for p in paths:
        s = Path(p).stem
        out.append(s if s not in out else f"{s}#{len(out)}")
    return out


COLUMNS = [  # (heading, key, format) of the stdout table
    ("n+1 mm", "err_n1_mm", "{:.2f}"), ("n+2 mm", "err_n2_mm", "{:.2f}"),
    ("rollout mm", "rollout_mm", "{:.1f}"), ("W2 mm", "w2_mm", "{:.1f}"),
    ("KE err", "ke_error", "{:.3f}"), ("COM err", "com_height_error", "{:.3f}"),
    ("order", "order_ok", "{}"), ("purity", "purity", "{:.3f}"),
    ("purity/SPH", "purity_ratio_min", "{:.2f}"), ("height W1", "height_w1_rel_max", "{:.3f}"),
    ("layers", "layers_ok", "{}"),
    ("vol err", "volume_error", "{:.4f}"), ("mom m/s", "momentum_error", "{:.3f}"),
    ("in walls", "in_walls_max", "{:.0f}"), ("entered", "entered_walls", "{:.0f}"), ("contacts/step", "contacts_per_step", "{:.1f}"),
    ("steps", "steps", "{}"), ("ms/step", "ms_per_step", "{:.1f}"),
]


def _cell(row, key, fmt):
    v = row.get(key)
    if v is None:
        return "-"
    if isinstance(v, bool) or key in ("order_ok", "layers_ok"):
        return "yes" if v is True or v == 1.0 else ("no" if v in (False, 0.0) else f"{v:.2f}")
    return fmt.format(v)


def _members_cell(row) -> str:
    """'mean [min–max] (orders right / members)' of the COM error over an ensemble."""
    m = row.get("members")
    if not m or m.get("com_height_error_mean") is None:
        return "-"
    return (f"{m['com_height_error_mean']:.3f} [{m['com_height_error_min']:.3f}–"
            f"{m['com_height_error_max']:.3f}] ({sum(map(bool, m['order_ok']))}/{m['n']} order)")


def format_table(results: dict) -> str:
    """Markdown table: per trajectory, a row per model and one for the SPH ground truth;
    with an ensemble (``--members``), a column of the COM error over its members."""
    ens = results.get("members", 1) > 1
    head = ["trajectory", "model"] + [c[0] for c in COLUMNS] + (["COM err, members"] if ens else [])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for traj, per_model in results["trajectories"].items():
        for label, row in per_model.items():
            cells = [_cell(row, k, f) for _, k, f in COLUMNS]
            if not row.get("stable", True):
                cells[len(COLUMNS) - 2] = f"{row['steps']} ({row['stop_cause']})"
            lines.append("| " + " | ".join([traj, label] + cells + ([_members_cell(row)] if ens else []))
                         + " |")
        any_row = next(iter(per_model.values()))
        sph = {"order_ok": any_row["order_ok_true"], "purity": any_row["purity_true"]}
        lines.append("| " + " | ".join([traj, "SPH (truth)"] +
                                       [_cell(sph, k, f) for _, k, f in COLUMNS] +
                                       (["-"] if ens else [])) + " |")
    for label, agg in results["aggregate"].items():
        cells = [_cell(agg, k, f) for _, k, f in COLUMNS]
        cells[-2] = f"{agg['stable']}/{agg['trajectories']} stable, min {agg['steps_min']}"
        lines.append("| " + " | ".join(["**all**", label] + cells + (["-"] if ens else [])) + " |")
    return "\n".join(lines)


def _plot(results: dict, out_dir: Path) -> list[Path]:
    """Per trajectory: rollout error and kinetic energy over time, one line per model."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..outputs import atomic_file

    written = []
    for traj, per_model in results["trajectories"].items():
        fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
        for label, row in per_model.items():
            c = row["curves"]
            a.plot(c["time"], c["rollout_mm"], label=label)
            b.plot(c["time"], c["ke_pred"], label=label)
        first = next(iter(per_model.values()))["curves"]
        b.plot(first["time"], first["ke_true"], "k--", label="SPH (truth)")
        a.set(xlabel="t [s]", ylabel="rollout error [mm]", title=f"{traj}: whole-rollout error")
        b.set(xlabel="t [s]", ylabel="kinetic energy [J]", title="kinetic energy")
        a.legend(fontsize=8)
        b.legend(fontsize=8)
        fig.tight_layout()
        path = out_dir / f"{traj}.png"
        with atomic_file(path) as tmp:
            fig.savefig(tmp, format="png", dpi=110)
        plt.close(fig)
        written.append(path)
    return written


@click.command("evaluate")
@click.option("--model", "models", multiple=True, required=True, type=click.Path(dir_okay=False),
              help="a checkpoint; repeat for several models side by side")
@click.option("--data", required=True, help="ground-truth dataset (directory or .h5)")
@click.option("--trajectory", "names", multiple=True, help="only these trajectories (repeatable)")
@click.option("--steps", type=int, default=None, help="rollout steps (default: every frame)")
@click.option("--start-frame", type=int, default=0, show_default=True,
              help="start the rollouts from this ground-truth frame instead of the initial "
                   "state (n+1 / n+2 still use every frame)")
@click.option("--stride", type=int, default=5, show_default=True,
              help="n+1 / n+2 errors from every STRIDE-th ground-truth frame")
@click.option("--max-speed", type=float, default=50.0, show_default=True, help="guard [m/s]")
@click.option("--max-in-walls", type=float, default=0.01, show_default=True, help="guard")
@click.option("--contact/--no-contact", default=CONTACT_DEFAULT,
              help="the walls' contact in the rollouts [default: each model's own; dcdc "
                   "simulate --help]")
@click.option("--members", type=int, default=1, show_default=True,
              help="rollouts per model and trajectory: member 0 from the stored start, the "
                   "others from starts displaced by --perturb (the rollouts are chaotic; the "
                   "table adds the COM error's mean and range over the members)")
@click.option("--perturb", type=float, default=1e-6, show_default=True,
              help="with --members > 1: rms displacement of the members' starts [m]")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None)
@click.option("--plots", "plot_dir", type=click.Path(file_okay=False), default=None,
              help="write error-over-time plots (PNG per trajectory) here")
@click.option("--overwrite", is_flag=True, help="replace an existing --json file / plots")
def evaluate_command(models, data, names, steps, start_frame, stride, max_speed, max_in_walls,
                     contact, members, perturb, json_path, plot_dir, overwrite):
    """Score models against the SPH ground truth: table on stdout, JSON, plots."""
    from tqdm import tqdm

    from ..data import interrupt
    from ..data.dataset import Dataset
    from ..outputs import check_dir, check_file, write_text
    from ..model.checkpoint import check_compatible, load_checkpoint
    from .rollout import Guard, uses_contact
    from .scores import aggregate, score_members

    if stride < 1:
        raise DcdcError(f"--stride must be >= 1 (got {stride})")
    if steps is not None and steps < 1:
        raise DcdcError(f"--steps must be >= 1 (got {steps})")
    if members < 1:
        raise DcdcError(f"--members must be >= 1 (got {members})")
    if not (math.isfinite(perturb) and perturb >= 0):
        raise DcdcError(f"--perturb must be a length >= 0 in metres (got {perturb})")
    if json_path:
        check_file(json_path, overwrite)
    if plot_dir:
        check_dir(plot_dir, overwrite=None)
    guard = Guard(max_speed=max_speed, max_in_walls=max_in_walls)
    ds = Dataset(data)
    trajs = [ds[n] for n in names] if names else list(ds)
    if not trajs:
        raise DcdcError(f"{data}: no finished trajectories to evaluate")
    for t in trajs:
        check_start_frame(t.name, t.n_frames, start_frame)
    nets = [load_checkpoint(m)[0] for m in models]
    labels = _labels(models)
    for net, m in zip(nets, models):  # every mismatch before any work
        for t in trajs:
            check_compatible(net, dim=t.dim, radius=t.radius, frame_dt=t.frame_dt,
                             what=f"trajectory {t.name} of {data}")
    results = {"data": str(data), "models": dict(zip(labels, map(str, models))),
               "stride": stride, "steps": steps, "start_frame": start_frame,
               "contact": {lab: uses_contact(net, contact) for lab, net in zip(labels, nets)},
               "members": members,
               "perturb_m": perturb if members > 1 else 0.0, "trajectories": {},
               "aggregate": {}}
    with interrupt.handling(), tqdm(total=len(trajs) * len(nets) * members, unit="rollout") as bar:
        for t in trajs:
            per = {}
            for label, net in zip(labels, nets):
                bar.set_postfix_str(f"{t.name} / {label}")
                per[label] = score_members(net, t, members, perturb, stride=stride,
                                           steps=steps, guard=guard, contact=contact,
                                           start_frame=start_frame)
                interrupt.check()
                bar.update(members)
            results["trajectories"][t.name] = per
    for label in labels:
        results["aggregate"][label] = aggregate([p[label] for p in results["trajectories"].values()])
    click.echo(format_table(results))
    if json_path:
        write_text(json_path, json.dumps(results, indent=1, sort_keys=True))
        click.echo(f"wrote {json_path}")
    if plot_dir:
        d = Path(plot_dir)
        d.mkdir(parents=True, exist_ok=True)
        for p in _plot(results, d):
            click.echo(f"wrote {p}")
