"""``dcdc benchmark cconv`` and ``dcdc benchmark model``: speed of the learned simulator here.

* ``cconv``: one C→C CConv layer (default 64→64, K = 4, 3-D) on a jittered lattice of
  ~30 k particles at the rest spacing 2r (≈ 43 neighbours within R = 4.5 r): forward and
  forward + backward time, peak memory, achieved GFLOP/s of the layer's GEMM work, and the
  ratio to the *GEMM-only bound* (the same GEMM shapes timed alone with torch.mm on this CPU).
* ``model``: milliseconds per neural step (Algorithm 1, neighbour search included, no
  gradients) for 1 k / 10 k / 50 k particles in 3-D for each network, with the breakdown
  search / geometry / convolutions (all network layers) / other, peak memory and threads.

Timings are the best of ``--repeat`` runs after a warm-up (the machine is shared; the
median is reported beside it for the whole step). Peak memory is the peak rise of
the process's resident set during the measured runs (sampled every 2 ms). ``cpu_ms_per_step``
is the process CPU time (all threads) per step: on a shared machine it is inflated far less
than wall time, and on an idle one wall ≈ cpu / threads for well-parallelised work. Optional: run with
``LD_PRELOAD=/usr/lib/x86_64-linux-gnu/libtcmalloc_minimal.so.4`` (Debian package
``libtcmalloc-minimal4``) — the CConv path reuses its buffers, so the gain is small.
"""
from __future__ import annotations

import json
import os
import platform
import statistics
import threading
import time

import click
import numpy as np
import torch

from ..particles import DEFAULT_RADIUS

R = 4.5 * DEFAULT_RADIUS
SPACING = 2 * DEFAULT_RADIUS


class PeakRSS:
    """Context manager: peak resident set size while inside — its rise above the RSS on entry
    (``peak_mib``; memory the allocator already holds from earlier work does not count) and
    the absolute process peak (``rss_mib``, includes Python/torch/numba, ~0.3–0.5 GiB)."""

    def __init__(self, interval: float = 0.002):
        self.interval = interval
        self.peak_mib = 0.0

    @staticmethod
    def _rss() -> int:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    def _poll(self):
        while not self._stop.is_set():
            self._max = max(self._max, self._rss())
            time.sleep(self.interval)

    def __enter__(self):
        self._base = self._max = self._rss()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self._max = max(self._max, self._rss())
        self.peak_mib = (self._max - self._base) / 2 ** 20  # rise above the RSS on entry
        self.rss_mib = self._max / 2 ** 20  # absolute peak RSS of the process


def _best_time(fn, repeat: int) -> float:
    """Best of ``repeat`` runs: the machine is shared, so the minimum is the stable statistic."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def lattice(n: int, dim: int = 3, seed: int = 0, jitter: float = 0.2) -> np.ndarray:
    """≈ n particles on a cubic lattice at spacing 2r, jittered by ±jitter·2r."""
    side = max(2, round(n ** (1 / dim)))
    g = np.arange(side) * SPACING
    x = np.stack(np.meshgrid(*[g] * dim, indexing="ij"), -1).reshape(-1, dim)
    return x + np.random.default_rng(seed).uniform(-jitter, jitter, x.shape) * SPACING


def machine_info() -> dict:
    import numba

    return {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "torch_threads": torch.get_num_threads(), "numba_threads": numba.get_num_threads(),
            "torch": torch.__version__, "ld_preload": os.environ.get("LD_PRELOAD", ""),
            "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY", ""),
            "loadavg_1_5_15min": [round(v, 2) for v in os.getloadavg()],
            "time": time.strftime("%Y-%m-%d %H:%M:%S")}


def _write_json(path, payload):
    """Write the results to ``path`` (checked before the work by the CLI) atomically."""
    if path:
        from ..outputs import write_text
        write_text(path, json.dumps(payload, indent=2) + "\n")
        click.echo(f"wrote {path}")


# --------------------------------------------------------------------------- one layer
def run_cconv(particles: int = 30000, channels: int = 64, kernel_size: int = 4,
              repeat: int = 3, bf16: bool = True, backends=("numba",)) -> dict:
    from .cconv import build_geometry, cconv

    x = lattice(particles)
    n = len(x)
    geom = build_geometry(x, radius=R, kernel_size=kernel_size)
    t_geom = _best_time(lambda: build_geometry(x, radius=R, kernel_size=kernel_size), repeat)
    ncell = kernel_size ** 3
    torch.manual_seed(0)
    F = torch.randn(n, channels, requires_grad=True)
    W = (torch.randn(ncell, channels, channels) * 0.02).requires_grad_()
    gemm_flops = 2.0 * n * ncell * channels * channels

    # GEMM-only bound: the layer's GEMMs alone (fwd: A@W; bwd: B@W'ᵀ and Fᵀ@B)
    A = torch.randn(n, ncell * channels)
    Wf = torch.randn(ncell * channels, channels)
    t_gemm = _best_time(lambda: A @ Wf, repeat)
    t_gemm_bwd = _best_time(lambda: (A @ Wf, F.detach().t() @ A), repeat)
    # the same GEMM fed in cache-sized row blocks, as the layer does (its buffer stays hot)
    from .cconv import CHUNK_BYTES

    rows = max(32, CHUNK_BYTES // (ncell * channels * 4))
    blk, out = A[:rows].clone(), torch.empty(n, channels)

    def blocked():
        for r0 in range(0, n, rows):
            r1 = min(n, r0 + rows)
            torch.mm(blk[: r1 - r0], Wf, out=out[r0:r1])

    t_gemm_blocked = _best_time(blocked, repeat)
    rows = []

    def measure(label, backend, gemm_dtype=None, grad=True):
        def fwd():
            with torch.no_grad():
                cconv(F, W, geom, backend, gemm_dtype)

        def fwd_bwd():
            F.grad = W.grad = None
            cconv(F, W, geom, backend).square().sum().backward()

        fwd()  # warm-up (compilation, sparse matrices)
        with PeakRSS() as mem_f:
            t_f = _best_time(fwd, repeat)
        row = {"variant": label, "particles": n, "edges": geom.n_edges,
               "neighbors": geom.n_edges / n, "fwd_s": t_f, "fwd_peak_mib": mem_f.peak_mib,
               "fwd_rss_mib": mem_f.rss_mib,
               "fwd_gflops": gemm_flops / t_f / 1e9, "fwd_vs_gemm_bound": t_f / t_gemm}
        if grad:
            fwd_bwd()
            with PeakRSS() as mem_b:
                t_b = _best_time(fwd_bwd, repeat)
            row.update({"fwd_bwd_s": t_b, "fwd_bwd_peak_mib": mem_b.peak_mib,
                        "fwd_bwd_rss_mib": mem_b.rss_mib,
                        "fwd_bwd_gflops": 3 * gemm_flops / t_b / 1e9,
                        "fwd_bwd_vs_gemm_bound": t_b / (t_gemm + t_gemm_bwd)})
        rows.append(row)

    for backend in backends:
        measure(f"{backend} fp32", backend)
    if bf16:
        measure("numba bf16 GEMM (inference)", "numba", torch.bfloat16, grad=False)
    return {"benchmark": "cconv", "machine": machine_info(),
            "setup": {"particles": n, "channels": f"{channels}->{channels}",
                      "kernel": f"{kernel_size}^3", "radius": R,
                      "mean_neighbors": geom.n_edges / n, "geometry_s": t_geom,
                      "gemm_gflop": gemm_flops / 1e9, "gemm_bound_fwd_s": t_gemm,
                      "gemm_bound_fwd_bwd_s": t_gemm + t_gemm_bwd,
                      "gemm_gflops": gemm_flops / t_gemm / 1e9,
                      "gemm_blocked_fwd_s": t_gemm_blocked,
                      "gemm_blocked_gflops": gemm_flops / t_gemm_blocked / 1e9},
            "rows": rows}


def run_fused_ab(sizes=(4000, 10000), widths=(("default", (32, 64, 64)), ("dcdc3d", (16, 32, 32))),
                 repeat: int = 5, echo=None) -> dict:
    """The fused CConv kernels against the unfused operator, alternated in this process.

    A 3-D ``dcdc`` network (float32) on :func:`tank` states; per size and widths, ``repeat``
    rounds each time the unfused ("numba") and the fused backend back to back: the
    convolutions of one step (forward, no gradients, the step's geometry prepared once) and a
    training iteration (forward + backward of a position loss, geometry included). Timings
    are wall-clock with more than one thread, CPU time with one (robust on a loaded machine);
    the ratio is the median over rounds of fused / unfused."""
    import numba

    from .networks import build_network

    threads = torch.get_num_threads()
    clock = time.perf_counter if max(threads, numba.get_num_threads()) > 1 else time.process_time
    rows = []
    for label, ch in widths:
        torch.manual_seed(0)
        net = build_network("dcdc", 3, channels=list(ch))
        for n in sizes:
            x, v, rho, wx, wn = tank(n)
            ctx = net.prepare(x, rho, wx)

            def fwd():
                with torch.no_grad():
                    net(x, v, rho, wx, wn, ctx=ctx)

            def train():
                net.zero_grad(set_to_none=True)
                vt = torch.tensor(v, dtype=torch.float32, requires_grad=True)
                net(x, vt, rho, wx, wn).square().sum().backward()

            times = {}
            for backend in ("numba", "fused", "numba", "fused"):  # warm-up (compilation)
                net.set_backend(backend)
                fwd()
                train()
            for _ in range(repeat):
                for backend in ("numba", "fused"):
                    net.set_backend(backend)
                    for kind, fn in (("fwd", fwd), ("train", train)):
                        t0, c0 = clock(), time.process_time()
                        fn()
                        times.setdefault((kind, backend), []).append(clock() - t0)
                        times.setdefault((kind + "_cpu", backend), []).append(
                            time.process_time() - c0)
            net.set_backend("auto")
            row = {"widths": label, "channels": list(ch), "particles": len(x), "walls": len(wx),
                   "threads": threads}
            for kind in ("fwd", "train"):
                a = np.array(times[(kind, "numba")])
                b = np.array(times[(kind, "fused")])
                row[f"{kind}_unfused_ms"] = float(np.median(a)) * 1e3
                row[f"{kind}_fused_ms"] = float(np.median(b)) * 1e3
                row[f"{kind}_ratio"] = float(np.median(b / a))
                row[f"{kind}_ratio_range"] = [float((b / a).min()), float((b / a).max())]
                a = np.array(times[(kind + "_cpu", "numba")])
                b = np.array(times[(kind + "_cpu", "fused")])
                row[f"{kind}_cpu_ratio"] = float(np.median(b / a))  # CPU time of all threads
            rows.append(row)
            if echo:
                echo(row)
    return {"benchmark": "cconv fused A/B", "machine": machine_info(), "rows": rows,
            "clock": "wall" if clock is time.perf_counter else "process CPU time",
            "note": "ratio = median over alternated rounds of fused / unfused time; fwd = the "
                    "convolutions of one step without gradients (geometry prepared once), "
                    "train = forward + backward of one step with its search and geometry"}


@click.command("cconv")
@click.option("--particles", default=30000, show_default=True, help="lattice particles (≈)")
@click.option("--channels", default=64, show_default=True, help="C_in = C_out")
@click.option("--kernel-size", default=4, show_default=True)
@click.option("--repeat", default=3, show_default=True)
@click.option("--bf16/--no-bf16", default=True, show_default=True,
              help="also time bf16 GEMMs (AMX) for inference")
@click.option("--torch-backend/--no-torch-backend", default=False, show_default=True,
              help="also time the pure-torch (sparse CSR) backend used on CUDA")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None,
              help="write results here (e.g. benchmarks/cconv.json)")
@click.option("--fused-ab", "fused_ab", default=None, metavar="SIZES",
              help="instead: the fused kernels against the unfused operator, alternated, in "
                   "3-D dcdc networks of the default and the dcdc3d widths at these particle "
                   "counts (e.g. 4000,10000)")
def cconv_command(particles, channels, kernel_size, repeat, bf16, torch_backend, json_path,
                  fused_ab):
    """One CConv layer: time, memory, GFLOP/s vs the GEMM-only bound."""
    if fused_ab:
        sizes = tuple(int(s) for s in fused_ab.split(","))

        def echo(r):
            click.echo(f"{r['widths']:8s} {r['particles']:6d} particles, {r['threads']} threads: "
                       f"step convolutions fused/unfused {r['fwd_ratio']:.2f} "
                       f"({r['fwd_fused_ms']:.0f} / {r['fwd_unfused_ms']:.0f} ms), training "
                       f"iteration {r['train_ratio']:.2f} ({r['train_fused_ms']:.0f} / "
                       f"{r['train_unfused_ms']:.0f} ms); CPU time ratios {r['fwd_cpu_ratio']:.2f}, "
                       f"{r['train_cpu_ratio']:.2f}")

        res = run_fused_ab(sizes, repeat=repeat, echo=echo)
        click.echo(f"(medians of {repeat} alternated rounds, {res['clock']})")
        _write_json(json_path, res)
        return
    backends = ("numba", "torch") if torch_backend else ("numba",)
    res = run_cconv(particles, channels, kernel_size, repeat, bf16, backends)
    s = res["setup"]
    click.echo(f"CConv {s['channels']}, kernel {s['kernel']}, {s['particles']} particles, "
               f"{s['mean_neighbors']:.1f} neighbours, threads torch "
               f"{res['machine']['torch_threads']} / numba {res['machine']['numba_threads']}, "
               f"load average {res['machine']['loadavg_1_5_15min'][0]}")
    click.echo(f"geometry (search + cells/weights): {s['geometry_s'] * 1e3:.0f} ms; GEMM bound: "
               f"fwd {s['gemm_bound_fwd_s'] * 1e3:.0f} ms, fwd+bwd "
               f"{s['gemm_bound_fwd_bwd_s'] * 1e3:.0f} ms ({s['gemm_gflops']:.0f} GFLOP/s); same GEMM "
               f"in cache-sized row blocks {s['gemm_blocked_fwd_s'] * 1e3:.0f} ms "
               f"({s['gemm_blocked_gflops']:.0f} GFLOP/s)")
    click.echo(f"{'variant':30s} {'fwd ms':>8s} {'GFLOP/s':>8s} {'×bound':>7s} {'+MiB':>6s} "
               f"{'fwd+bwd ms':>11s} {'GFLOP/s':>8s} {'×bound':>7s} {'+MiB':>6s}")
    for r in res["rows"]:
        line = (f"{r['variant']:30s} {r['fwd_s'] * 1e3:8.0f} {r['fwd_gflops']:8.0f} "
                f"{r['fwd_vs_gemm_bound']:7.2f} {r['fwd_peak_mib']:6.0f}")
        if "fwd_bwd_s" in r:
            line += (f" {r['fwd_bwd_s'] * 1e3:11.0f} {r['fwd_bwd_gflops']:8.0f} "
                     f"{r['fwd_bwd_vs_gemm_bound']:7.2f} {r['fwd_bwd_peak_mib']:6.0f}")
        click.echo(line)
    _write_json(json_path, res)


# --------------------------------------------------------------------------- whole step
def tank(n: int, dim: int = 3, seed: int = 0):
    """A two-phase block (heavy below, light above) of ≈ n particles on a wall floor/sides."""
    x = lattice(n, dim, seed)
    top = x[:, 1] > np.median(x[:, 1])
    rho = np.where(top, 1000.0, 2000.0)
    lo, hi = x.min(0) - SPACING, x.max(0) + SPACING
    walls, normals = [], []
    for axis in range(dim):
        if axis == 1:
            sides = [(lo, 1.0)]  # floor only, open top
        else:
            sides = [(lo, 1.0), (hi, -1.0)]
        for corner, sign in sides:
            others = [a for a in range(dim) if a != axis]
            grids = [np.arange(lo[a], hi[a] + 1e-9, SPACING) for a in others]
            pts = np.stack(np.meshgrid(*grids, indexing="ij"), -1).reshape(-1, dim - 1)
            w = np.empty((len(pts), dim))
            w[:, others] = pts
            w[:, axis] = corner[axis]
            nrm = np.zeros_like(w)
            nrm[:, axis] = sign
            walls.append(w)
            normals.append(nrm)
    v = np.random.default_rng(seed + 1).normal(scale=0.1, size=x.shape)
    return x, v, rho, np.concatenate(walls), np.concatenate(normals)


def run_model(sizes=(1000, 10000, 50000), networks=("dcdc", "cconv", "dcdc-antisym"),
              repeat: int = 5, bf16: bool = False, echo=None, train: bool = False,
              net_options: dict | None = None, device: str = "cpu") -> dict:
    """Time neural steps; with ``train`` a step is forward + backward of a position loss.
    ``net_options``: network options (e.g. ``kernel_size``, ``channels``) for every network.
    On ``device = "cuda"`` the network runs on the GPU (the neighbour search and the
    geometry stay on the CPU) and every timed step ends with a device synchronisation."""
    from .integrator import step
    from .networks import build_network

    dev = torch.device(device)
    sync = torch.cuda.synchronize if dev.type == "cuda" else (lambda: None)
    rows = []
    for name in networks:
        torch.manual_seed(0)
        net = build_network(name, 3, **(net_options or {})).eval().to(dev)
        if bf16:
            net.set_backend("auto", torch.bfloat16)
        for n in sizes:
            x, v, rho, wx, wn = tank(n)
            xt = torch.tensor(x, dtype=torch.float32, device=dev)
            vt = torch.tensor(v, dtype=torch.float32, device=dev)
            def one_step():
                if not train:
                    with torch.no_grad():
                        out = step(net, xt, vt, rho, wx, wn)
                    sync()
                    return out
                net.zero_grad(set_to_none=True)
                x1, _ = step(net, xt, vt, rho, wx, wn)
                with net._timed("backward"):
                    (x1 - xt).square().sum().backward()
                    sync()

            one_step()  # warm-up
            net.profile, net.timings = True, {}
            totals = []
            cpu0 = time.process_time()
            with PeakRSS() as mem:
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    one_step()
                    totals.append(time.perf_counter() - t0)
            cpu = (time.process_time() - cpu0) / repeat
            net.profile = False
            parts = {k: v_ / repeat for k, v_ in net.timings.items()}
            mean_total = sum(totals) / repeat
            pairs = np.diff(net.last_context.fluid.row_splits)  # fluid neighbours, self included
            row = {"network": name, "options": dict(net_options or {}),
                   "particles": len(x), "walls": len(wx),
                   "neighbours_mean": float(pairs.mean()) if len(pairs) else 0.0,
                   "ms_per_step": min(totals) * 1e3,
                   "ms_per_step_median": statistics.median(totals) * 1e3,
                   "cpu_ms_per_step": cpu * 1e3,
                   "search_ms": parts.get("search", 0) * 1e3,
                   "geometry_ms": parts.get("geometry", 0) * 1e3,
                   "convolutions_ms": parts.get("convolutions", 0) * 1e3,
                   "backward_ms": parts.get("backward", 0) * 1e3, "train": train,
                   "other_ms": (mean_total - sum(parts.values())) * 1e3,
                   "peak_mib": mem.peak_mib, "rss_mib": mem.rss_mib, "bf16": bf16}
            row["device"] = str(dev)
            rows.append(row)
            if echo:
                echo(row)
    return {"benchmark": "model", "machine": machine_info(), "device": str(dev), "rows": rows,
            "scaling": scaling_exponents(rows),
            "note": "no gradients, float32 (+bf16 GEMMs if set); ms_per_step = best of repeats, "
                    "breakdown = means over repeats (other = mean total - parts); scaling: "
                    "least-squares slope of log(median ms) over log(particles) per network"}


def scaling_exponents(rows) -> dict:
    """Per network, the fitted b of median ms ∝ N^b (linear cost: b ≈ 1); needs ≥ 2 sizes."""
    out = {}
    for name in dict.fromkeys(r["network"] for r in rows):
        pts = [(r["particles"], r["ms_per_step_median"]) for r in rows if r["network"] == name]
        if len({n for n, _ in pts}) >= 2:
            n, ms = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            out[name] = float(np.polyfit(n, ms, 1)[0])
    return out


def _fmt_row(r):
    return (f"{r['network']:13s} {r['particles']:7d} {r['ms_per_step']:9.1f} "
            f"{r['ms_per_step_median']:8.1f} "
            f"{r['search_ms']:8.1f} {r['geometry_ms']:9.1f} {r['convolutions_ms']:8.1f} "
            f"{r['other_ms']:7.1f} {r['peak_mib']:7.0f} {r['rss_mib']:7.0f}"
            + f" {r['cpu_ms_per_step']:8.1f}"
            + (f" {r['backward_ms']:9.1f}" if r["train"] else ""))


@click.command("model")
@click.option("--particles", default="1000,10000,50000", show_default=True,
              help="comma-separated particle counts (3-D)")
@click.option("--networks", default="dcdc,cconv,dcdc-antisym", show_default=True)
@click.option("--repeat", default=5, show_default=True)
@click.option("--bf16/--no-bf16", default=False, show_default=True,
              help="bf16 GEMMs (AMX) for inference")
@click.option("--train", is_flag=True, help="time forward + backward (a training step)")
@click.option("--kernel-size", type=int, default=None, help="network option kernel_size "
              "(default: the architecture's, 4)")
@click.option("--channels", default=None, help="network option channels, comma-separated "
              "hidden widths (default: 32,64,64)")
@click.option("--radius-scale", type=float, default=None, help="network option radius_scale: "
              "the convolution radius in particle radii (default: 4.5)")
@click.option("--device", default="cpu", show_default=True, help="where the network runs (cuda)")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None,
              help="write results here (e.g. benchmarks/model.json)")
def model_command(particles, networks, repeat, bf16, train, kernel_size, channels, radius_scale,
                  device, json_path):
    """ms per neural step (search included) per network and particle count."""
    from ..errors import DcdcError

    if device.startswith("cuda") and not torch.cuda.is_available():
        raise DcdcError(f"--device {device}: no CUDA device here (torch {torch.__version__})")

    try:
        sizes = [int(s) for s in particles.split(",") if s.strip()]
    except ValueError:
        raise DcdcError(f"--particles must be comma-separated integers (got {particles!r})") from None
    nets = [s.strip() for s in networks.split(",") if s.strip()]
    opts = {}
    if kernel_size is not None:
        opts["kernel_size"] = kernel_size
    if radius_scale is not None:
        if not radius_scale > 0:
            raise DcdcError(f"--radius-scale must be > 0 (got {radius_scale})")
        opts["radius_scale"] = radius_scale
    if channels:
        try:
            opts["channels"] = tuple(int(c) for c in channels.split(",") if c.strip())
        except ValueError:
            raise DcdcError(f"--channels must be comma-separated integers (got {channels!r})") from None
    info = machine_info()
    if train and bf16:
        raise DcdcError("--bf16 is for inference; leave it out with --train")
    click.echo(f"{'training' if train else 'neural'} step (Δt = 0.02 s), 3-D, "
               f"float32{' + bf16 GEMMs' if bf16 else ''}, "
               f"threads torch {info['torch_threads']} / numba {info['numba_threads']}, "
               f"load average {info['loadavg_1_5_15min'][0]}"
               + (f", options {opts}" if opts else ""))
    click.echo("(ms/step: best wall time; cpu ms: CPU time of all threads per step, which "
               "load from other processes inflates less)")
    click.echo(f"{'network':13s} {'N':>7s} {'ms/step':>9s} {'median':>8s} {'search':>8s} {'geometry':>9s} "
               f"{'convs':>8s} {'other':>7s} {'+MiB':>7s} {'RSS MiB':>7s} {'cpu ms':>8s}"
               + (f" {'backward':>9s}" if train else ""))
    res = run_model(sizes, nets, repeat, bf16, echo=lambda r: click.echo(_fmt_row(r)),
                    train=train, net_options=opts, device=device)
    for name, b in res["scaling"].items():
        click.echo(f"scaling {name}: median ms ∝ N^{b:.2f}")
    _write_json(json_path, res)
