"""Matplotlib side views of particle states (``dcdc scene show`` draws with these).

A frame is drawn as a side view (x horizontal, y up): the whole 2-D domain, or for 3-D the
slab of particles within two spacings of the mid-plane z = const, fluid coloured by phase,
walls grey. Trajectories are drawn by :mod:`.figures` (``dcdc render``) instead.
"""
from __future__ import annotations

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
