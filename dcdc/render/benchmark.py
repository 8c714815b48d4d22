"""``dcdc benchmark render``: frames per second of ``dcdc render`` on this machine, and the
small synthetic trajectory it (and the tests) draw.

:func:`block_trajectory` writes a dataset-layout trajectory without running a solver: a
two-phase block of particles on the rest lattice (heavy lower half, light upper half) in
an open wall box, every particle moved by a travelling wave so that frames differ. The
benchmark times the picture alone (:meth:`FrameRenderer.draw`) and the whole command to
an MP4 (labels and H.264 encoding included), in frames per second and in CPU seconds per
frame (all threads and the encoder process: on a shared machine the wall-clock rate
depends on the load, the CPU time much less).
"""
from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import click
import numpy as np

from ..particles import ParticleSystem, Phase

PHASES = [Phase("heavy", 3000.0, 1e-6, (0.82, 0.23, 0.16)),
          Phase("light", 1000.0, 1e-6, (0.23, 0.47, 0.85))]


def _box_walls(lo, hi, spacing, dim):
    """One layer of wall particles on the floor and side faces of [lo, hi], normals inward."""
    axes = [np.arange(lo[a], hi[a] + 1e-9, spacing) for a in range(dim)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    xs, ns = [], []
    for a in range(dim):
        for side, sign in ((lo[a], 1.0), (hi[a], -1.0)):
            if a == 1 and sign < 0:
                continue  # open top
            on = np.isclose(grid[:, a], side)
            n = np.zeros((on.sum(), dim))
            n[:, a] = sign
            xs.append(grid[on])
            ns.append(n)
    return np.concatenate(xs), np.concatenate(ns)


def block_trajectory(path, dim: int = 3, n: int = 10_000, frames: int = 10,
                     radius: float = 0.025, frame_dt: float = 0.02, name: str = "block",
                     attrs: dict | None = None) -> Path:
    """Write a synthetic trajectory of ``n`` particles (see the module docstring);
    ``attrs`` add to or replace its metadata (e.g. a ``scene_toml``)."""
    from ..data.dataset import write_trajectory
    s = 2 * radius
    side = int(np.ceil(n ** (1 / dim)))
    idx = np.stack(np.meshgrid(*[np.arange(side)] * dim, indexing="ij"), -1).reshape(-1, dim)
    idx = idx[np.lexsort(idx.T[::-1])][:n] if dim == 2 else idx[:n]
    x0 = (idx + 0.5) * s + s
    phase = (x0[:, 1] > np.median(x0[:, 1])).astype(np.int32)
    hi_box = x0.max(0) + 1.5 * s
    hi_box[1] += 4 * s
    wall_x, wall_n = _box_walls(np.zeros(dim), hi_box, s, dim)
    t = np.arange(frames + 1) * frame_dt
    k = 2 * np.pi / max(hi_box[0], 1e-9)
    wave = np.sin(k * x0[None, :, 0] - 2 * np.pi * t[:, None])          # [T, N]
    xs = np.repeat(x0[None], len(t), 0)
    xs[..., 1] += 0.5 * s * wave
    vs = np.zeros_like(xs)
    vs[..., 1] = -0.5 * s * 2 * np.pi * np.cos(k * x0[None, :, 0] - 2 * np.pi * t[:, None])
    gravity = np.zeros(dim)
    gravity[1] = -9.81
    system = ParticleSystem(dim, radius, x0, np.zeros_like(x0), phase, PHASES, wall_x, wall_n,
                            gravity, (np.full(dim, -s), hi_box + s), name=name)
    attrs = {"frame_dt": frame_dt, "scene": name, "scene_dim": dim, "solver": "synthetic",
             "split": "", "seed": 0, "resolution": 1.0, **(attrs or {})}
    return write_trajectory(Path(path), name, xs, vs, t, system, attrs)


def _cpu() -> float:
    """CPU seconds of this process (all threads) and its finished children (ffmpeg)."""
    import os
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@click.command("render")
@click.option("--particles", default=10_000, show_default=True, type=int)
@click.option("--frames", default=30, show_default=True, type=int)
@click.option("--width", default=800, show_default=True, type=int)
@click.option("--dim", type=click.Choice(["2", "3"]), default="3", show_default=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=None)
def benchmark_command(particles, frames, width, dim, json_path):
    """Frames per second of dcdc render (picture alone, and the whole command to MP4)."""
    import os

    from .cli import render_command
    from .figures import open_trajectory
    from .frames import FrameRenderer, default_camera

    with tempfile.TemporaryDirectory() as tmp:
        path = block_trajectory(Path(tmp) / "block.h5", int(dim), particles, frames)
        traj = open_trajectory(path)
        cam = default_camera(traj, width)
        r = FrameRenderer(traj, cam)
        r.draw(0)  # compile
        load = os.getloadavg()[0]
        t0, c0 = time.perf_counter(), _cpu()
        for f in range(traj.n_frames):
            r.draw(f)
        n = traj.n_frames
        draw_fps, draw_cpu = n / (time.perf_counter() - t0), (_cpu() - c0) / n
        t0, c0 = time.perf_counter(), _cpu()
        render_command.main([str(path), "--out", str(Path(tmp) / "b.mp4"), "--width",
                             str(width), "--no-progress"], standalone_mode=False)
        total_fps, total_cpu = n / (time.perf_counter() - t0), (_cpu() - c0) / n
        rec = {"particles": particles, "walls": len(traj.wall_x), "dim": int(dim),
               "frames": n, "width": cam.width, "height": cam.height,
               "draw_fps": round(draw_fps, 2), "draw_cpu_s_per_frame": round(draw_cpu, 4),
               "render_mp4_fps": round(total_fps, 2),
               "render_mp4_cpu_s_per_frame": round(total_cpu, 4),
               "cores": os.cpu_count(), "load_average_start": load,
               "load_average_end": os.getloadavg()[0]}
    click.echo(f"{particles} particles ({dim}-D) + {rec['walls']} walls, "
               f"{cam.width} x {cam.height} px, supersample 2, load average {load:.1f}")
    click.echo(f"{'':<40}{'frames/s':>10}{'CPU s/frame':>14}")
    click.echo(f"{'picture alone':<40}{draw_fps:>10.1f}{draw_cpu:>14.3f}")
    click.echo(f"{'dcdc render to MP4 (labels, encoding)':<40}{total_fps:>10.1f}{total_cpu:>14.3f}")
    if json_path:
        from ..outputs import write_text
        write_text(json_path, json.dumps(rec, indent=1) + "\n")
