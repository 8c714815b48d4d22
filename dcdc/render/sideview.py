"""Pictures and animations of trajectories (the last stage of the data flow).

A frame is drawn as a side view (x horizontal, y up): the whole 2-D domain, or for 3-D the
slab of particles within two spacings of the mid-plane z = const, fluid coloured by phase,
walls grey. :func:`snapshot_strip` puts several frames side by side (a PNG for the README);
:func:`animate` writes every k-th frame to a GIF or MP4.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def side_view(ax, x, colors, wall_x, dim: int, spacing: float, lo, hi, ms: float | None = None,
              ticks: bool = False) -> None:
    """Scatter fluid (per-particle ``colors``) and walls (grey) seen along z, x right, y up;
    in 3-D only the slab within two spacings of the mid-plane of [lo, hi]. The marker size
    ``ms`` defaults to one particle spacing at the axes' scale."""
    if dim == 3:
        zc = 0.5 * (lo[2] + hi[2])
        keep = np.abs(x[:, 2] - zc) < 2 * spacing
        x, colors = x[keep], colors[keep]
        wall_x = wall_x[np.abs(wall_x[:, 2] - zc) < 2 * spacing]
    if ms is None:
        span = max(hi[0] - lo[0], hi[1] - lo[1])
        ms = max(0.3, 9.0 * (spacing / span) * 100) ** 2 / 9
    ax.scatter(wall_x[:, 0], wall_x[:, 1], s=ms, c="0.65", marker="s", linewidths=0)
    ax.scatter(x[:, 0], x[:, 1], s=ms, c=colors, linewidths=0)
    ax.set_aspect("equal")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    if not ticks:
        ax.set_xticks([])
        ax.set_yticks([])


def _frame_bounds(traj):
    w = traj.wall_x
    pos = traj.position[0]
    both = np.concatenate([w, pos]) if len(w) else pos
    pad = 2 * traj.radius
    return both.min(0) - pad, both.max(0) + pad


def snapshot_strip(traj, path, frames=None, n: int = 4, title: str | None = None) -> Path:
    """Frames of ``traj`` (a :class:`dcdc.data.dataset.Trajectory`) side by side in one PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if frames is None:
        frames = np.linspace(0, traj.n_frames - 1, n).round().astype(int)
    lo, hi = _frame_bounds(traj)
    aspect = (hi[1] - lo[1]) / max(hi[0] - lo[0], 1e-9)
    fig, axes = plt.subplots(1, len(frames), figsize=(3.2 * len(frames), 3.2 * aspect + 0.6))
    axes = np.atleast_1d(axes)
    colors = np.array([p.color for p in traj.phases])
    birth, times = traj.birth, traj.time
    for ax, f in zip(axes, frames):
        active = birth <= times[f] + 1e-9
        side_view(ax, traj.position[f][active], colors[traj.phase[active]], traj.wall_x,
                  traj.dim, 2 * traj.radius, lo, hi)
        ax.set_title(f"t = {times[f]:.2f} s", fontsize=9)
    labels = [f"{p.name} ({p.density:g})" for p in traj.phases]
    handles = [plt.Line2D([], [], marker="o", ls="", color=c) for c in colors]
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return path


def animate(traj, path, every: int = 2, fps: int = 25) -> Path:
    """Every ``every``-th frame of ``traj`` to a GIF or MP4 (by the file extension)."""
    import imageio.v3 as iio
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lo, hi = _frame_bounds(traj)
    aspect = (hi[1] - lo[1]) / max(hi[0] - lo[0], 1e-9)
    colors = np.array([p.color for p in traj.phases])
    images = []
    for f in range(0, traj.n_frames, every):
        fig, ax = plt.subplots(figsize=(4, 4 * aspect))
        active = traj.birth <= traj.time[f] + 1e-9
        side_view(ax, traj.position[f][active], colors[traj.phase[active]], traj.wall_x,
                  traj.dim, 2 * traj.radius, lo, hi)
        ax.set_title(f"{traj.name}  t = {traj.time[f]:.2f} s", fontsize=8)
        fig.canvas.draw()
        images.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
        plt.close(fig)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".part" + path.suffix)
    if path.suffix.lower() == ".gif":
        iio.imwrite(tmp, np.stack(images), duration=1000 / fps, loop=0)
    else:
        iio.imwrite(tmp, np.stack(images), fps=fps)
    tmp.replace(path)
    return path
