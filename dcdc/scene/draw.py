"""Pictures of a particle system's state (initial state of a scene, dataset frames):
matplotlib side views (x horizontal, y up) of the whole 2-D domain, or for 3-D of the slab of
particles within two spacings of the mid-plane z = const, fluid coloured by phase, walls
grey. Trajectories are drawn by :mod:`dcdc.render` (``dcdc render``) instead."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DcdcError
from ..outputs import atomic_file, check_file
from ..particles import ParticleSystem


def draw(system: ParticleSystem, path, title: str | None = None, x=None, active=None) -> Path:
    """Draw fluid (coloured by phase) and walls (grey) to an image file.

    2-D: one scatter plot. 3-D: a perspective view of the fluid with the front half of the
    walls cut away, and a side view of the slab |z - z_mid| < 2 spacings (cross-section).
    ``x`` overrides the fluid positions (e.g. a later frame), ``active`` masks particles.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = system.x if x is None else np.asarray(x)
    if active is None:
        active = system.birth <= 0
    colors = np.array([p.color for p in system.phases])[system.phase]
    x, colors = x[active], colors[active]
    w = system.wall_x
    lo, hi = system.domain
    title = title or system.name
    counts = ", ".join(f"{k} {v}" for k, v in system.counts_per_phase().items())
    ms = max(0.5, min(30.0, 2.5e4 / max(len(x) + len(w), 1)))
    if system.dim == 2:
        fig, ax = plt.subplots(figsize=(7, 7 * (hi[1] - lo[1]) / max(hi[0] - lo[0], 1e-9) * 0.9 + 0.8))
        side_view(ax, x, colors, w, 2, system.spacing, lo - 0.1, hi + 0.1, ms=ms, ticks=True)
        ax.set_title(f"{title} (2-D): {counts}", fontsize=9)
    else:
        fig = plt.figure(figsize=(13, 6))
        ax = fig.add_subplot(1, 2, 1, projection="3d")
        zc = 0.5 * (lo[2] + hi[2])
        # floors (normals up) in full, other walls with their front half cut away
        keep = (system.wall_n[:, 1] > 0.5) | (w[:, 2] >= zc)
        back = w[keep]
        fs = float(np.clip(3e4 / max(len(x), 1), 1.0, 20.0))
        ax.scatter(back[:, 0], back[:, 2], back[:, 1], s=1.5, c=back[:, 1], cmap="gist_earth", alpha=0.4, linewidths=0)
        ax.scatter(x[:, 0], x[:, 2], x[:, 1], s=fs, c=colors, linewidths=0, depthshade=True)
        ax.set_xlabel("x"); ax.set_ylabel("z"); ax.set_zlabel("y")
        ext = (hi - lo).max() / 2
        c = (hi + lo) / 2
        ax.set_xlim(c[0] - ext, c[0] + ext); ax.set_ylim(c[2] - ext, c[2] + ext)
        ax.set_zlim(c[1] - ext, c[1] + ext)
        ax.view_init(elev=20, azim=-60)
        ax.set_title(f"{title} (3-D): {counts}", fontsize=9)
        ax2 = fig.add_subplot(1, 2, 2)
        slab = 2 * system.spacing
        side_view(ax2, x, colors, w, 3, system.spacing, lo - 0.1, hi + 0.1, ms=5, ticks=True)
        ax2.set_title(f"side view, slab |z - {zc:.2f}| < {slab:.2f}", fontsize=9)
    for p, col in zip(system.phases, [p.color for p in system.phases]):
        plt.scatter([], [], c=[col], label=f"{p.name} ({p.density:g} kg/m³)")
    fig.legend(loc="lower center", ncol=max(1, len(system.phases)), fontsize=8, frameon=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_file(path) as tmp:  # a picture is never half-written
            fig.savefig(tmp, dpi=90, bbox_inches="tight", format=path.suffix[1:].lower() or "png")
    finally:
        plt.close(fig)
    return path


def check_image(path, overwrite: bool = False) -> Path:
    """Check, before any work, that ``path`` can be written and names a picture format
    matplotlib writes (by its suffix; none = PNG)."""
    from matplotlib.backend_bases import FigureCanvasBase
    path = check_file(path, overwrite)
    fmt = path.suffix[1:].lower()
    formats = FigureCanvasBase.get_supported_filetypes()
    if fmt and fmt not in formats:
        raise DcdcError(f"{path}: unknown picture format {path.suffix!r} (use "
                        f"{', '.join('.' + f for f in sorted(formats))})")
    return path


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
