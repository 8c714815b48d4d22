"""What ``dcdc render`` makes: an animation, a strip of time points (the paper's Figs 1–3)
or a side-by-side comparison of two trajectories, all from :class:`~.frames.FrameRenderer`
pictures with the labels of :mod:`.overlay`.

* animation: one picture per selected frame, a title (trajectory, solver), and below it
  the time, the legend (phase names and rest densities) and a scale bar;
* strip: the frames nearest to the requested times side by side, each titled with its
  time, one legend and scale bar for all (same camera);
* compare: A (e.g. SPH ground truth) and B (e.g. a neural rollout) through the same camera
  at the same frames, captioned with the mean nearest-particle distance in mm
  (:mod:`.compare`); with a strip, A is the top row and B the bottom row.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from .compare import mean_nearest_distance
from .frames import AXES, FrameRenderer, parse_cut, scene_bounds
from .overlay import font_size, hstack, legend_band, note, title_band, vstack


def open_trajectory(path, name: str | None = None, warn=None):
    """The trajectory ``name`` of the dataset file/directory ``path``; without a name the
    only one it holds. Its positions are checked first (what ``render``, ``export`` and
    ``view`` read): a trajectory without frames or without one finite position is an
    error; non-finite positions in some frames (a diverged run) are reported through
    ``warn`` (default: a ``note:`` line on stderr)."""
    from ..data.dataset import Dataset
    ds = Dataset(path)
    if name is not None:
        traj = ds[name]
    elif len(ds) == 1:
        traj = ds[0]
    elif len(ds) == 0:
        raise DcdcError(f"{path}: holds no complete trajectory")
    else:
        names = ", ".join(ds.names[:5]) + (", …" if len(ds) > 5 else "")
        raise DcdcError(f"{path} holds {len(ds)} trajectories ({names}): choose one with "
                        f"--trajectory")
    check_positions(traj, path, warn)
    return traj


def check_positions(traj, path, warn=None, block_bytes: int = 2**26) -> None:
    """Scan the stored positions of ``traj`` (in blocks of frames of about ``block_bytes``):
    raise for no frames or no finite position, ``warn`` about frames holding non-finite
    ones."""
    if traj.n_frames == 0:
        raise DcdcError(f"{path}: trajectory {traj.name} holds no frames")
    n = traj.n_particles
    if n == 0:
        return
    step = max(1, block_bytes // (n * traj.dim * 4))
    bad_frames, bad_values, first = 0, 0, None
    for a in range(0, traj.n_frames, step):
        x = traj._get("position", slice(a, min(a + step, traj.n_frames)))
        bad = ~np.isfinite(x).all(axis=2)
        per_frame = bad.sum(axis=1)
        if first is None and per_frame.any():
            first = a + int(np.flatnonzero(per_frame)[0])
        bad_frames += int((per_frame > 0).sum())
        bad_values += int(per_frame.sum())
    if bad_values == traj.n_frames * n:
        raise DcdcError(f"{path}: trajectory {traj.name} holds no finite position (all "
                        f"{traj.n_frames} frames are NaN or infinite: the run diverged)")
    if bad_values:
        text = (f"{path}: trajectory {traj.name} has {bad_values} non-finite particle "
                f"positions in {bad_frames} of {traj.n_frames} frames, from frame {first} (the "
                f"run that wrote it diverged?)")
        if warn is None:
            import click
            click.echo(f"note: {text}", err=True)
        else:
            warn(text)


def select_frames(traj, frames: str | None = None, stride: int = 1) -> list[int]:
    """``frames`` "A:B" (Python slice of frame indices, either end optional, negative from
    the end) with step ``stride``; default all frames."""
    if stride < 1:
        raise DcdcError(f"--stride must be >= 1 (got {stride})")
    start = stop = None
    if frames:
        parts = frames.split(":")
        try:
            if len(parts) == 1:
                start = int(parts[0])
                stop = start + 1 if start != -1 else None
            elif len(parts) == 2:
                start = int(parts[0]) if parts[0] else None
                stop = int(parts[1]) if parts[1] else None
            else:
                raise ValueError
        except ValueError:
            raise DcdcError(f"--frames {frames!r}: expected A:B (frame indices, e.g. 0:100)") from None
    sel = list(range(traj.n_frames))[slice(start, stop, stride)]
    if not sel:
        raise DcdcError(f"--frames {frames!r} selects no frame of {traj.name} "
                        f"(frames 0..{traj.n_frames - 1})")
    return sel


def strip_frames(traj, times: str) -> list[int]:
    """Frame indices nearest to the comma-separated ``times`` [s]."""
    try:
        ts = [float(t) for t in times.split(",") if t.strip()]
    except ValueError:
        raise DcdcError(f"--strip {times!r}: expected times in seconds, e.g. 0,1,2.5") from None
    if not ts:
        raise DcdcError("--strip needs at least one time")
    t = traj.time
    half = 0.5 * (float(traj.frame_dt) if traj.n_frames > 1 else 0.0) + 1e-9
    out = []
    for s in ts:
        if not t[0] - half <= s <= t[-1] + half:
            raise DcdcError(f"--strip time {s:g} s is outside {traj.name} "
                            f"({t[0]:g} .. {t[-1]:g} s)")
        out.append(int(np.argmin(np.abs(t - s))))
    return out


def describe(traj) -> str:
    solver = str(traj.attrs.get("solver", "") or "")
    return f"{traj.name} · {solver}" if solver else traj.name


def cut_label(cut) -> str:
    axis, value = cut
    return f"cut-away: {AXES[axis]} > {value:.3g} m removed"


@dataclass
class Figure:
    """Pictures of one or two trajectories through one camera."""

    renderers: list[FrameRenderer]
    cut: tuple | None = None
    labels: list[str] | None = None  # one title per trajectory (default: name · solver)

    @classmethod
    def build(cls, trajs, camera, cut_text=None, supersample=2, walls=True):
        a = trajs[0]
        for b in trajs[1:]:
            if b.dim != a.dim:
                raise DcdcError(f"cannot compare a {a.dim}-D with a {b.dim}-D trajectory")
        lo, hi = scene_bounds(a)
        cut = parse_cut(cut_text, a.dim, lo, hi)
        return cls([FrameRenderer(t, camera, supersample, cut, walls) for t in trajs], cut)

    def label(self, k: int) -> str:
        return self.labels[k] if self.labels else describe(self.trajs[k])

    @property
    def trajs(self):
        return [r.traj for r in self.renderers]

    @property
    def camera(self):
        return self.renderers[0].camera

    def picture(self, k: int, f: int) -> np.ndarray:
        img = self.renderers[k].draw(f)
        return note(img, cut_label(self.cut)) if self.cut else img

    @property
    def font(self) -> int:
        """One label size for the whole figure, set by the width of one picture."""
        return font_size(self.camera.width)

    def title(self, width: int, text: str) -> np.ndarray:
        return title_band(width, text, self.font)

    def legend(self, width: int, left: str | None = None) -> np.ndarray:
        a = self.trajs[0]
        return legend_band(width, a.phases, self.camera.pixels_per_metre_at_target(), a.dim,
                           left, self.font)

    def error_mm(self, f: int) -> float:
        """Mean nearest-particle distance between A and B at frame ``f`` (all particles
        present, cut away or not; NaN when either has none) [mm]."""
        return 1000 * mean_nearest_distance(*(r.present(f) for r in self.renderers[:2]),
                                            2 * self.trajs[0].radius)

    # ------------------------------------------------------------- the three figures
    def frame(self, f: int) -> np.ndarray:
        """One animation frame: a single trajectory, or A | B with the error caption."""
        t = float(self.trajs[0].time[f])
        if len(self.renderers) == 1:
            img = self.picture(0, f)
            w = img.shape[1]
            return vstack(self.title(w, self.label(0)), img,
                          self.legend(w, f"t = {t:.2f} s"))
        pics = [vstack(self.title(self.camera.width, self.label(k)), self.picture(k, f))
                for k in range(len(self.trajs))]
        row = hstack(pics)
        w = row.shape[1]
        caption = f"t = {t:.2f} s    mean nearest-particle distance {self.error_mm(f):.1f} mm"
        return vstack(row, self.title(w, caption), self.legend(w))

    def write_video(self, path, frames, fps: float, overwrite: bool = False,
                    progress=None) -> Path:
        """:meth:`frame` of each of ``frames`` to a GIF, an MP4 or a folder of PNGs (by the
        name of ``path``), written atomically; ``progress(1)`` after each frame."""
        from .video import FrameWriter, frame_output, output_kind
        with frame_output(path, overwrite) as tmp, \
                FrameWriter(tmp, output_kind(path), fps) as writer:
            for f in frames:
                writer.append(self.frame(f))
                if progress is not None:
                    progress(1)
        return Path(path)

    def strip(self, frames: list[int]) -> np.ndarray:
        """The frames side by side; two rows (A over B) when comparing."""
        cw = self.camera.width
        rows = []
        for k, tr in enumerate(self.trajs):
            cells = []
            for f in frames:
                head = f"t = {float(tr.time[f]):.2f} s"
                if len(self.trajs) > 1 and k == 1:
                    head += f"   error {self.error_mm(f):.1f} mm"
                cells.append(vstack(self.title(cw, head), self.picture(k, f)))
            row = hstack(cells)
            rows.append(vstack(self.title(row.shape[1], self.label(k)), row))
        img = vstack(*rows)
        return vstack(img, self.legend(img.shape[1]))


# ------------------------------------------------------- Python conveniences (dcdc demo)
def snapshot_strip(traj, path, frames=None, n: int = 4, title: str | None = None,
                   width: int = 360) -> Path:
    """``n`` evenly spaced frames (or ``frames``) of ``traj`` side by side in one PNG,
    written atomically."""
    from PIL import Image

    from .frames import default_camera
    from .output import atomic_file
    if frames is None:
        frames = np.linspace(0, traj.n_frames - 1, n).round().astype(int).tolist()
    fig = Figure.build([traj], default_camera(traj, width))
    fig.labels = [title] if title else None
    with atomic_file(path) as tmp:
        Image.fromarray(fig.strip(list(frames))).save(tmp, format="PNG", optimize=True)
    return Path(path)


def animate(traj, path, every: int = 2, fps: int = 25, width: int = 480) -> Path:
    """Every ``every``-th frame of ``traj`` to a GIF, an MP4 or a folder of PNGs (by the
    name), with legend, time and scale bar."""
    from .frames import default_camera
    fig = Figure.build([traj], default_camera(traj, width))
    return fig.write_video(path, range(0, traj.n_frames, every), fps, overwrite=True)
