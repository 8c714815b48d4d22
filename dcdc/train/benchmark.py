"""``dcdc benchmark train``: speed of one training iteration.

One iteration = the trainer's own :func:`~dcdc.train.loss.unrolled_loss` over
``--unroll`` (default 2) neural steps, backward, and an Adam step, on the two-phase tank of
:func:`dcdc.model.benchmark.tank` (2-D ≈ 1 k and 3-D ≈ 4 k particles by default, default
widths, float32, warm). The networks are measured **interleaved** — iteration k of every
network before iteration k + 1 of any — so load from other processes on a shared machine
affects them alike and their *ratio* is meaningful even when the absolute times are not.

Throughput is reported as particle-steps per second: particles × unrolled steps / time of
one iteration (median of the repeats; the best is in the JSON too). ``cpu ms`` is the
process CPU time of an iteration (all threads): load from other processes inflates it far
less than wall time, so its dcdc/cconv ratio is the steadier one on a shared machine.
"""
from __future__ import annotations

import statistics
import time

import click
import numpy as np
import torch

from ..errors import DcdcError
from ..particles import FRAME_DT

CASES = ((2, 1000), (3, 4000))


def _batch(dim: int, n: int, unroll: int):
    from ..model.benchmark import tank
    from .sampler import collate

    x, v, rho, wx, wn = tank(n, dim)
    frames = np.stack([x + k * FRAME_DT * v for k in range(unroll + 1)])  # targets: any frames
    g = np.zeros(dim)
    g[1] = -9.81
    return collate([{"position": frames, "velocity": v, "density": rho, "wall_position": wx,
                     "wall_normal": wn, "gravity": g}])


def run_train_benchmark(cases=CASES, networks=("dcdc", "cconv"), repeat: int = 5,
                        unroll: int = 2, echo=None) -> dict:
    """Interleaved timings of fwd + bwd + Adam per network and case; a JSON-ready dict."""
    from ..model.benchmark import machine_info
    from ..model.networks import build_network
    from .config import LossConfig
    from .loss import unrolled_loss

    loss_cfg = LossConfig(unroll=unroll)
    rows = []
    for dim, n in cases:
        batch = _batch(dim, n, unroll)
        setups = {}
        for name in networks:
            torch.manual_seed(0)
            net = build_network(name, dim)
            setups[name] = (net, torch.optim.Adam(net.parameters(), lr=1e-4, eps=1e-6))

        def iteration(name):
            net, opt = setups[name]
            t0, c0 = time.perf_counter(), time.process_time()
            opt.zero_grad(set_to_none=True)
            loss, _ = unrolled_loss(net, batch, loss_cfg)
            loss.backward()
            opt.step()
            return time.perf_counter() - t0, time.process_time() - c0

        for name in networks:  # warm-up: compilation caches, allocator, Adam state
            iteration(name)
        times = {name: [] for name in networks}
        cpu = {name: [] for name in networks}
        for _ in range(repeat):
            for name in networks:
                wall_s, cpu_s = iteration(name)
                times[name].append(wall_s)
                cpu[name].append(cpu_s)
        for name in networks:
            med, best = statistics.median(times[name]), min(times[name])
            row = {"network": name, "dim": dim, "particles": batch.n_particles,
                   "walls": int(batch.wall_position.shape[0]), "unroll": unroll,
                   "ms_median": med * 1e3, "ms_best": best * 1e3,
                   "cpu_ms_median": statistics.median(cpu[name]) * 1e3,
                   "ms_samples": [t * 1e3 for t in times[name]],
                   "particle_steps_per_s": batch.n_particles * unroll / med}
            rows.append(row)
            if echo:
                echo(row)
    ratios = {}
    if "dcdc" in networks and "cconv" in networks:
        for dim, _ in cases:
            a = next(r for r in rows if r["network"] == "dcdc" and r["dim"] == dim)
            b = next(r for r in rows if r["network"] == "cconv" and r["dim"] == dim)
            ratios[f"{dim}d_dcdc_over_cconv"] = a["ms_median"] / b["ms_median"]
            ratios[f"{dim}d_dcdc_over_cconv_cpu"] = a["cpu_ms_median"] / b["cpu_ms_median"]
    return {"benchmark": "train", "machine": machine_info(), "rows": rows, "ratios": ratios,
            "note": f"one iteration = {unroll} unrolled neural steps (search included) + "
                    "backward + Adam, float32, default widths; networks interleaved; "
                    "particle_steps_per_s = particles * unroll / median"}


@click.command("train")
@click.option("--networks", default="dcdc,cconv", show_default=True)
@click.option("--repeat", default=5, show_default=True, help="timed iterations per network")
@click.option("--unroll", default=2, show_default=True, help="neural steps per iteration")
@click.option("--quick", is_flag=True, help="tiny sizes (a smoke test, not a measurement)")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None,
              help="write results here (e.g. benchmarks/train.json)")
def train_benchmark_command(networks, repeat, unroll, quick, json_path):
    """ms per training iteration and particle-steps/s, dcdc vs cconv (2-D 1 k, 3-D 4 k)."""
    from ..model.benchmark import _write_json

    nets = [s.strip() for s in networks.split(",") if s.strip()]
    if repeat < 1 or unroll < 1:
        raise DcdcError("--repeat and --unroll must be >= 1")
    cases = ((2, 64), (3, 64)) if quick else CASES
    click.echo(f"training iteration: {unroll} unrolled steps + backward + Adam, float32 "
               f"(networks interleaved, median of {repeat})")
    click.echo(f"{'network':8s} {'dim':>3s} {'N':>6s} {'ms median':>10s} {'ms best':>8s} "
               f"{'cpu ms':>8s} {'particle-steps/s':>17s}")
    res = run_train_benchmark(cases, nets, repeat, unroll, echo=lambda r: click.echo(
        f"{r['network']:8s} {r['dim']:3d} {r['particles']:6d} {r['ms_median']:10.1f} "
        f"{r['ms_best']:8.1f} {r['cpu_ms_median']:8.1f} {r['particle_steps_per_s']:17.0f}"))
    for k, v in res["ratios"].items():
        click.echo(f"{k}: {v:.2f}")
    _write_json(json_path, res)
