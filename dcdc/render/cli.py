"""``dcdc render``, ``dcdc export`` and ``dcdc view``: see and move trajectories.

Every command checks its output path before any work (an existing output needs
``--overwrite``), writes under a temporary name and renames when done, and reports a
missing or corrupt file or an unknown trajectory as one ``error:`` line.
"""
from __future__ import annotations

import click

from ..errors import DcdcError

def _progress(total, enabled, desc):
    from tqdm import tqdm
    return tqdm(total=total, unit="frame", desc=desc, disable=not enabled)


def _fps(traj, stride, fps):
    if fps is not None:
        if not 0 < fps <= 1000:  # nan fails too
            raise DcdcError(f"--fps must be a number of frames per second in (0, 1000] "
                            f"(got {fps})")
        return fps
    return float(min(max(round(1.0 / (traj.frame_dt * stride)), 1), 50))  # real time


def _save_png(img, path, palette=None):
    from PIL import Image
    im = Image.fromarray(img)
    if palette:
        im = im.quantize(colors=palette, method=Image.Quantize.MEDIANCUT)
    im.save(path, format="PNG", optimize=True)


@click.command("render")
@click.argument("traj_path", metavar="[TRAJ]", required=False, type=click.Path())
@click.option("--out", "-o", "out", required=True, type=click.Path(),
              help="FILE.mp4, FILE.gif, FILE.png (a --strip or a single frame) or a folder "
                   "name (one PNG per frame)")
@click.option("--trajectory", "-t", "name", default=None,
              help="trajectory in a file holding several")
@click.option("--compare", nargs=2, type=click.Path(), default=None, metavar="A B",
              help="two trajectories side by side (e.g. SPH and model), same camera and frames")
@click.option("--strip", default=None, metavar="T1,T2,…",
              help="one picture of these times [s] side by side")
@click.option("--frames", default=None, metavar="A:B", help="frame index range (Python slice)")
@click.option("--stride", default=1, show_default=True, type=int, help="every k-th frame")
@click.option("--fps", type=float, default=None, help="default: real time (max 50)")
@click.option("--width", type=int, default=None,
              help="pixels per picture (default 800, 360 per strip panel, 480 per compared panel)")
@click.option("--height", type=int, default=None, help="default: from the scene's shape")
@click.option("--azimuth", type=float, default=None, help="3-D: degrees about the vertical axis (0 = front)")
@click.option("--elevation", type=float, default=None, help="3-D: degrees above the horizon")
@click.option("--distance", type=float, default=None, help="3-D: camera distance from the centre [m]")
@click.option("--zoom", type=float, default=1.0, show_default=True)
@click.option("--cut", default=None, metavar="AXIS[=VALUE]",
              help="3-D cut-away: drop everything with x[AXIS] > VALUE (default the centre)")
@click.option("--no-walls", is_flag=True, help="do not draw the walls")
@click.option("--supersample", type=int, default=2, show_default=True, help="anti-aliasing factor")
@click.option("--palette", type=click.IntRange(2, 256), default=None, metavar="N",
              help="PNG pictures with an adaptive palette of N colours (smaller files)")
@click.option("--overwrite", is_flag=True, help="replace an existing output")
@click.option("--no-progress", is_flag=True)
def render_command(traj_path, out, name, compare, strip, frames, stride, fps, width, height,
                   azimuth, elevation, distance, zoom, cut, no_walls, supersample, palette,
                   overwrite, no_progress):
    """Render TRAJ (a dataset file or directory: SPH data or a neural rollout) as an
    animation, a strip of time points, or side by side with another (--compare A B)."""
    from .figures import Figure, describe, open_trajectory, select_frames, strip_frames
    from .frames import default_camera
    from .output import atomic_file, check_output
    from .video import output_kind

    if bool(traj_path) == bool(compare):
        raise DcdcError("give either TRAJ or --compare A B")
    kind = output_kind(out)
    if strip and kind != "png":
        raise DcdcError(f"{out}: a --strip is one picture; name the output .png")
    check_output(out, overwrite, directory=kind == "folder", replaceable=(".png",))
    trajs = [open_trajectory(p, name) for p in ([traj_path] if traj_path else compare)]
    if width is None:
        width = 360 if strip else 480 if compare else 800
    if width < 16 or (height is not None and height < 16):
        raise DcdcError("--width and --height must be at least 16 pixels")
    camera = default_camera(trajs[0], width, height, azimuth=azimuth, elevation=elevation,
                            distance=distance, zoom=zoom)
    fig = Figure.build(trajs, camera, cut, supersample, not no_walls)
    if compare:  # the two may share a name: say which file is which
        fig.labels = [f"{describe(t)} — {p}" for t, p in zip(trajs, compare)]
    n_common = min(t.n_frames for t in trajs)
    if compare:
        import numpy as np
        ta, tb = (t.time[:n_common] for t in trajs)
        if not np.allclose(ta, tb, atol=1e-6):
            raise DcdcError(f"{compare[0]} and {compare[1]}: frames are at different times")
    if strip:
        sel = strip_frames(trajs[0], strip)
        if max(sel) >= n_common:
            raise DcdcError(f"--strip: {compare[1]} has only {n_common} frames")
        with atomic_file(out) as tmp:
            _save_png(fig.strip(sel), tmp, palette)
        click.echo(f"wrote {out} ({len(sel)} time points)")
        return
    sel = [f for f in select_frames(trajs[0], frames, stride) if f < n_common]
    if kind == "png":
        if len(sel) != 1:
            raise DcdcError(f"{out}: a .png holds one picture; select one frame (--frames N) "
                            f"or use --strip, a .mp4/.gif or a folder name")
        with atomic_file(out) as tmp:
            _save_png(fig.frame(sel[0]), tmp, palette)
        click.echo(f"wrote {out}")
        return
    rate = _fps(trajs[0], stride, fps)
    with _progress(len(sel), not no_progress, "render") as bar:
        fig.write_video(out, sel, rate, overwrite, bar.update)
    click.echo(f"wrote {out} ({len(sel)} frames at {rate:g} fps)")


@click.command("export")
@click.argument("traj_path", metavar="TRAJ", type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["ply", "vtk"]), required=True,
              help="ply: one PLY per frame (Blender); vtk: VTU per frame + .pvd (ParaView)")
@click.option("--out", "-o", "out", required=True, type=click.Path(), help="output directory")
@click.option("--trajectory", "-t", "name", default=None)
@click.option("--frames", default=None, metavar="A:B", help="frame index range (Python slice)")
@click.option("--stride", default=1, show_default=True, type=int)
@click.option("--overwrite", is_flag=True, help="replace an existing export directory")
@click.option("--no-progress", is_flag=True)
def export_command(traj_path, fmt, out, name, frames, stride, overwrite, no_progress):
    """Write every frame of TRAJ as point clouds for Blender (PLY) or ParaView (VTU + PVD)."""
    from .export import export_trajectory
    from .figures import open_trajectory, select_frames
    from .output import atomic_dir, check_output

    check_output(out, overwrite, directory=True, replaceable=(".ply", ".vtu", ".pvd"))
    traj = open_trajectory(traj_path, name)
    sel = select_frames(traj, frames, stride)
    with atomic_dir(out, overwrite=overwrite) as tmp, \
            _progress(len(sel), not no_progress, "export") as bar:
        files = export_trajectory(traj, fmt, tmp, sel, bar.update,
                                  warn=lambda text: click.echo(f"note: {text}", err=True))
    click.echo(f"wrote {len(files)} files to {out}")


@click.command("view")
@click.argument("traj_path", metavar="TRAJ", type=click.Path())
@click.option("--html", "out", required=True, type=click.Path(), help="output page (.html)")
@click.option("--trajectory", "-t", "name", default=None)
@click.option("--max-frames", default=200, show_default=True, type=int,
              help="keep every k-th frame so that at most this many remain")
@click.option("--stride", default=1, show_default=True, type=int, help="at least every k-th frame")
@click.option("--overwrite", is_flag=True, help="replace an existing page")
def view_command(traj_path, out, name, max_frames, stride, overwrite):
    """Write TRAJ as one offline HTML page playing it (WebGL, orbit camera, phase toggles)."""
    from pathlib import Path

    from .figures import open_trajectory
    from .output import atomic_file, check_output
    from .view import page_data, render_page, view_frames

    if Path(out).suffix.lower() not in (".html", ".htm"):
        raise DcdcError(f"{out}: the page must end in .html")
    check_output(out, overwrite)
    traj = open_trajectory(traj_path, name)
    frames = view_frames(traj.n_frames, max_frames, stride)
    page = render_page(page_data(traj, frames))
    with atomic_file(out) as tmp:
        Path(tmp).write_text(page, encoding="utf-8")
    click.echo(f"wrote {out} ({len(frames)} frames, {len(page) / 1e6:.1f} MB)")
