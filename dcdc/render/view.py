"""``dcdc view``: one self-contained HTML file that plays a trajectory in the browser.

The page (``viewer.html``, plain WebGL 1 written for dcdc, no library, no network) gets
the data inlined as one JSON object:

* fluid positions of the kept frames quantised to uint16 within the scene's box
  (error <= box size / 131 070, under 0.01 mm per metre of box), base64;
* phase index (uint8) and emission time (float32) per particle, phase names, densities and
  colours, frame times;
* wall positions (uint16) and normals (int8), base64: the page draws a wall point only
  where its normal faces the camera, so the front walls are cut away at every angle;
* mesh walls as faint triangles (:func:`mesh_data`), culled the same way;
* the speed |v| of every particle in every kept frame quantised to uint8 in [0, the largest
  speed of those frames] (step <= ``speed_max`` / 255), base64, and the colour map
  (matplotlib's viridis sampled at 17 points, interpolated linearly in the page) for the
  speed and rest-density colourings and their colour bar.

The page colours by phase, speed or rest density (the legend, or a colour bar with its
range), shows a scale bar (a length of 1, 2 or 5 x 10^k m at the depth of the view's
centre) and plays at 0.1x to 4x real time.

Frames are subsampled to at most ``max_frames`` (every k-th frame with the smallest k that
fits, the last frame always kept) so the file stays small: 7 bytes per particle and frame
before base64 (+33 %).
"""
from __future__ import annotations

import base64
import json
from importlib import resources

import numpy as np

from ..errors import DcdcError
from ..particles import active_mask
from .camera import DEFAULT_VIEW, PRESETS, fit_camera
from .frames import scene_bounds

TEMPLATE = "viewer.html"
PLACEHOLDER = "/*DCDC_DATA*/"


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def view_frames(n_frames: int, max_frames: int, stride: int = 1) -> list[int]:
    """Every k-th frame (k >= ``stride``, smallest that keeps <= ``max_frames``), plus the
    last frame."""
    if max_frames < 1 or stride < 1:
        raise DcdcError("--max-frames and --stride must be >= 1")
    k = max(stride, int(np.ceil(n_frames / max_frames)))
    sel = list(range(0, n_frames, k))
    if sel[-1] != n_frames - 1 and len(sel) < max_frames:
        sel.append(n_frames - 1)
    return sel


def _quantise(x: np.ndarray, lo: np.ndarray, span: np.ndarray) -> np.ndarray:
    q = np.round(np.nan_to_num((x - lo) / span, nan=0.0) * 65535.0)  # NaN: a corner
    return np.clip(q, 0, 65535).astype("<u2")


COLORMAP_POINTS = 17


def colormap(points: int = COLORMAP_POINTS) -> list[list[float]]:
    """matplotlib's viridis at ``points`` evenly spaced values, RGB in [0, 1]."""
    import matplotlib
    rgb = matplotlib.colormaps["viridis"](np.linspace(0.0, 1.0, points))[:, :3]
    return np.round(rgb, 4).tolist()


def speeds(traj, frames: list[int]) -> tuple[np.ndarray, float]:
    """|v| [F, N] quantised to uint8 in [0, vmax] and vmax [m/s], the largest speed of the
    particles present in ``frames`` (1 when nothing moves, so the scale is never empty)."""
    out = np.zeros((len(frames), traj.n_particles), np.uint8)
    if not traj.n_particles:
        return out, 1.0
    s = np.stack([np.linalg.norm(traj._get("velocity", f).astype(np.float64), axis=1)
                  for f in frames])
    s = np.nan_to_num(s, nan=0.0, posinf=0.0)
    birth, death, t = traj.birth, getattr(traj, "death", None), traj.time
    present = np.stack([active_mask(birth, death, float(t[f])) for f in frames])
    vmax = float(np.max(np.where(present, s, 0.0))) or 1.0
    out[:] = np.clip(np.round(s / vmax * 255.0), 0, 255)
    return out, vmax


def page_data(traj, frames: list[int]) -> dict:
    """The JSON object the page reads (see the module docstring)."""
    dim = traj.dim
    lo, hi = scene_bounds(traj)
    pad3 = (lambda a: np.concatenate([a, np.zeros(a.shape[:-1] + (1,), a.dtype)], -1)) \
        if dim == 2 else (lambda a: a)
    lo3, hi3 = pad3(lo[None])[0], pad3(hi[None])[0]
    hi3 = np.where(hi3 - lo3 > 0, hi3, lo3 + traj.radius)  # the flat z of 2-D gets a span
    span = hi3 - lo3
    x = np.stack([pad3(traj._get("position", f).astype(np.float64)) for f in frames]) \
        if traj.n_particles else np.zeros((len(frames), 0, 3))
    walls = pad3(np.asarray(traj.wall_x, np.float64))
    normals = pad3(np.asarray(traj.wall_n, np.float64))
    if len(traj.phases) > 16:
        raise DcdcError(f"{traj.name}: the viewer shows at most 16 phases ({len(traj.phases)})")
    if dim == 3:
        az, el = PRESETS.get(str(traj.attrs.get("scene", "")), DEFAULT_VIEW)
        cam = fit_camera(lo, hi, 800, 600, azimuth=az, elevation=el)
        distance = float(np.linalg.norm(np.subtract(cam.eye, cam.target)))
    else:
        az, el = 0.0, 0.0
        cam = fit_camera(np.r_[lo, 0.0], np.r_[hi, traj.radius], 800, 600, azimuth=0, elevation=0)
        distance = float(np.linalg.norm(np.subtract(cam.eye, cam.target)))
    solver = str(traj.attrs.get("solver", "") or "")
    speed, vmax = speeds(traj, frames)
    return {
        "name": traj.name, "dim": dim, "radius": traj.radius, "n": traj.n_particles,
        "n_walls": len(walls), "lo": lo3.tolist(), "hi": hi3.tolist(),
        "info": f"{dim}-D, {traj.n_particles} particles, {len(frames)} of {traj.n_frames} "
                f"frames" + (f", {solver}" if solver else ""),
        "times": [float(traj.time[f]) for f in frames], "frames": frames,
        "phases": [{"name": p.name, "density": p.density, "color": list(p.color)}
                   for p in traj.phases],
        "azimuth": az, "elevation": el, "distance": distance,
        "positions": _b64(_quantise(x, lo3, span)),
        "phase": _b64(traj.phase.astype(np.uint8)),
        "birth": _b64(traj.birth.astype("<f4")),
        "wall_positions": _b64(_quantise(walls, lo3, span)),
        "wall_normals": _b64(np.clip(np.round(normals * 127), -127, 127).astype(np.int8)),
        "speed": _b64(speed), "speed_max": vmax, "colormap": colormap(),
        **mesh_data(traj),
    }


def mesh_data(traj) -> dict:
    """Mesh walls (:mod:`.walls`) as unindexed triangles, float32 positions and int8 face
    normals per vertex, each triangle wound counter-clockwise seen from the fluid side (the
    page culls back faces: the same cut-away as for wall particles). Empty without meshes."""
    from .walls import wall_meshes
    meshes, _ = wall_meshes(traj)
    if not meshes:
        return {}
    pos, nrm = [], []
    for m in meshes:
        tris = m.triangles.copy()
        v = m.vertices[tris]
        n = m.fluid_normals()
        flip = np.einsum("ij,ij->i", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), n) < 0
        tris[flip] = tris[flip][:, ::-1]
        pos.append(m.vertices[tris].reshape(-1, 3))
        nrm.append(np.repeat(n, 3, axis=0))
    return {"mesh_positions": _b64(np.concatenate(pos).astype("<f4")),
            "mesh_normals": _b64(np.clip(np.round(np.concatenate(nrm) * 127), -127, 127)
                                 .astype(np.int8))}


def render_page(data: dict) -> str:
    """The viewer page with ``data`` inlined (``</`` escaped so no string ends the script)."""
    template = resources.files("dcdc.render").joinpath(TEMPLATE).read_text(encoding="utf-8")
    blob = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return template.replace(PLACEHOLDER, f"var DATA = {blob};", 1)
