"""Frames of a trajectory as pictures: particles as shaded spheres, walls faint.

:class:`FrameRenderer` draws frame ``f`` of a :class:`~dcdc.data.dataset.Trajectory`
(SPH data and neural rollouts share the layout) through a :class:`~.camera.Camera`:

* fluid particles as spheres of the particle radius, coloured with the phase colours stored
  in the file, z-buffered (:mod:`.splat`), only those already emitted at that time;
* walls as a translucent grey layer (drawn once: they do not move). In 3-D only the wall
  particles whose normal faces the camera are kept, i.e. the back walls and the floor; the
  front walls, which would hide the fluid, are cut away. Mesh walls (:mod:`.walls`) are
  drawn as their triangles, culled the same way, over the wall particles sampled under
  their surface. ``cut=(axis, value)`` also removes
  fluid and walls with ``x[axis] > value`` (a labelled cut-away into the volume);
* rendered at ``supersample`` times the size and box-filtered down (anti-aliasing).
"""
from __future__ import annotations

import numpy as np

from ..errors import DcdcError
from ..particles import active_mask
from .camera import Camera, fit_camera
from .splat import LIGHT, MATERIAL, clear, resolve, shade_layer, splat, splat_triangles

BACKGROUND = np.array([0.975, 0.975, 0.97])
WALL_COLOR = np.array([0.55, 0.56, 0.6])
WALL_ALPHA = {2: 0.3, 3: 0.25}
AXES = "xyz"
MAX_SIDE = 16384  # pixels per side of a picture (video encoders and viewers stop near here)
MAX_SUPERSAMPLE = 16
CANVAS_BYTES = 48  # per supersampled pixel: depth, ids, wall colours and the frame buffers
_NONE2, _NONE3 = np.zeros((0, 0)), np.zeros((0, 0, 3))  # "no walls" for resolve()


def parse_cut(text: str | None, dim: int, lo, hi) -> tuple[int, float] | None:
    """``"z"`` (remove the half beyond the box centre) or ``"z=0.3"`` / ``"x=-0.1"``."""
    if not text:
        return None
    if dim != 3:
        raise DcdcError("--cut applies to 3-D trajectories only")
    name, _, value = text.partition("=")
    name = name.strip().lower()
    if name not in AXES:
        raise DcdcError(f"--cut {text!r}: expected x, y or z, optionally =VALUE (e.g. z=0.2)")
    axis = AXES.index(name)
    if not value:
        return axis, 0.5 * float(lo[axis] + hi[axis])
    try:
        return axis, float(value)
    except ValueError:
        raise DcdcError(f"--cut {text!r}: {value!r} is not a number") from None


def scene_bounds(traj) -> tuple[np.ndarray, np.ndarray]:
    """Box around the walls and the fluid (first, middle and last frame), padded by one
    particle radius, clipped to the stored domain."""
    parts = [traj.wall_x] if len(traj.wall_x) else []
    T = traj.n_frames
    for f in sorted({0, T // 2, T - 1}):
        parts.append(traj._get("position", f))
    pts = np.concatenate([p for p in parts if len(p)]) if any(len(p) for p in parts) else \
        np.zeros((1, traj.dim))
    pts = pts[np.isfinite(pts).all(1)]
    if not len(pts):
        pts = np.zeros((1, traj.dim))
    pad = traj.radius
    lo, hi = pts.min(0) - pad, pts.max(0) + pad
    dlo = np.asarray(traj.attrs.get("domain_min", lo), np.float64)
    dhi = np.asarray(traj.attrs.get("domain_max", hi), np.float64)
    lo, hi = np.maximum(lo, dlo), np.minimum(hi, dhi)
    if np.any(hi <= lo):
        lo, hi = pts.min(0) - pad, pts.max(0) + pad
    return lo, hi


def default_camera(traj, width: int, height: int | None = None, **view) -> Camera:
    lo, hi = scene_bounds(traj)
    return fit_camera(lo, hi, width, height, scene=str(traj.attrs.get("scene", "")), **view)


def check_canvas(width: int, height: int, supersample: int) -> None:
    """Refuse, before allocating, a picture too large to draw: a side over
    :data:`MAX_SIDE` pixels, a supersampling factor outside 1..:data:`MAX_SUPERSAMPLE`, or
    a supersampled canvas over half this machine's memory."""
    if not 1 <= supersample <= MAX_SUPERSAMPLE:
        raise DcdcError(f"--supersample must be from 1 to {MAX_SUPERSAMPLE} (got {supersample})")
    if max(width, height) > MAX_SIDE:
        raise DcdcError(f"a picture of {width} x {height} pixels is too large: at most "
                        f"{MAX_SIDE} pixels a side (--width, --height)")
    from ..scene.budget import physical_memory
    need = float(width) * height * supersample**2 * CANVAS_BYTES
    mem = physical_memory()
    if mem and need > 0.5 * mem:
        raise DcdcError(f"a picture of {width} x {height} pixels at --supersample "
                        f"{supersample} needs {need / 2**30:.1f} GiB, more than half of this "
                        f"machine's {mem / 2**30:.1f} GiB: lower --width or --supersample")


class FrameRenderer:
    """Draws frames of ``traj`` seen by ``camera`` as uint8 RGB arrays [H, W, 3]."""

    def __init__(self, traj, camera: Camera, supersample: int = 2,
                 cut: tuple[int, float] | None = None, walls: bool = True):
        if camera.dim != traj.dim:
            raise DcdcError(f"a {camera.dim}-D camera cannot show a {traj.dim}-D trajectory")
        check_canvas(camera.width, camera.height, supersample)
        self.traj, self.camera, self.ss, self.cut = traj, camera, int(supersample), cut
        self.shape = (camera.height * self.ss, camera.width * self.ss)
        self.colors = np.array([p.color for p in traj.phases], np.float64).reshape(-1, 3)
        self.phase, self.birth, self.times = traj.phase, traj.birth, traj.time
        self.death = getattr(traj, "death", None)
        if len(self.phase) and self.phase.max() >= len(self.colors):
            raise DcdcError(f"{traj.name}: phase index {self.phase.max()} but only "
                            f"{len(self.colors)} phases are stored")
        self.wall_alpha = WALL_ALPHA[traj.dim]
        from .walls import wall_meshes
        self.meshes, self.notes = wall_meshes(traj) if walls else ([], [])
        self._walls = self._draw_walls() if walls and (len(traj.wall_x) or self.meshes) else None
        self._buffers = None

    def _keep(self, x: np.ndarray) -> np.ndarray:
        if self.cut is None:
            return np.ones(len(x), bool)
        axis, value = self.cut
        return x[:, axis] <= value

    def _project(self, x):
        sx, sy, depth, ppm = self.camera.project(x)
        s = self.ss
        return sx * s, sy * s, depth, ppm * s * self.traj.radius

    def _draw_walls(self):
        x, n = self.traj.wall_x, self.traj.wall_n
        keep = self._keep(x) & self.camera.faces_camera(x, n)
        zbuf = np.full(self.shape, np.inf)
        ids = np.full(self.shape, -1, np.int32)
        sx, sy, depth, rad = self._project(x[keep])
        sx, sy, rad, _ = splat(sx, sy, depth, rad, self.traj.radius, zbuf, ids)
        rgb = np.zeros(self.shape + (3,))
        colors = np.broadcast_to(WALL_COLOR, (len(sx), 3)).copy()
        shade_layer(ids, sx, sy, rad, colors, LIGHT, MATERIAL, rgb)
        for mesh in self.meshes:  # nearer than the wall particles sampled under them
            self._draw_mesh(mesh, zbuf, rgb)
        return zbuf, rgb

    def _draw_mesh(self, mesh, zbuf, rgb):
        """The triangles of a mesh wall whose fluid side faces the camera (the same cut-away
        as for wall particles), flat-shaded, into the wall layer."""
        cam = self.camera
        normals = mesh.fluid_normals()
        centres = mesh.vertices[mesh.triangles].mean(1)
        keep = cam.faces_camera(centres, normals) & self._keep(centres)
        px, py, pz, _ = cam.project(mesh.vertices)
        r, u, f = cam.basis()
        n_cam = np.stack([normals @ r, normals @ u, -(normals @ f)], 1)  # z towards the eye
        shade = MATERIAL[0] + MATERIAL[1] * np.maximum(n_cam @ LIGHT, 0.0)
        splat_triangles(px * self.ss, py * self.ss, pz, np.ascontiguousarray(mesh.triangles[keep]),
                        np.ascontiguousarray(shade[keep]), WALL_COLOR, zbuf, rgb,
                        self.traj.radius)  # the particle spheres under it poke out by r

    def _present(self, f: int):
        x = self.traj._get("position", f)
        return x, active_mask(self.birth, self.death, float(self.times[f])) & np.isfinite(x).all(1)

    def present(self, f: int) -> np.ndarray:
        """Positions of the particles emitted by frame ``f`` with finite coordinates (a
        diverged rollout may hold NaN)."""
        x, ok = self._present(f)
        return x[ok]

    def fluid(self, f: int):
        """Positions and colours of the particles drawn at frame ``f``: :meth:`present`
        and not cut away."""
        x, ok = self._present(f)
        keep = ok & self._keep(x)
        return x[keep], self.colors[self.phase[keep]]

    def draw(self, f: int, x: np.ndarray | None = None, colors=None) -> np.ndarray:
        """Frame ``f`` (or the given positions/colours) as uint8 [H, W, 3]."""
        if x is None:
            x, colors = self.fluid(f)
        if self._buffers is None:  # reused: fresh pages for every frame cost more than drawing
            self._buffers = (np.empty(self.shape, np.float32), np.empty(self.shape, np.int32))
        zbuf, ids = self._buffers
        clear(zbuf, ids)
        sx, sy, depth, rad = self._project(x)
        sx, sy, rad, order = splat(sx, sy, depth, rad, self.traj.radius, zbuf, ids)
        colors = np.ascontiguousarray(np.asarray(colors, np.float64).reshape(-1, 3)[order])
        out = np.empty((self.camera.height, self.camera.width, 3), np.uint8)
        wz, wrgb = self._walls if self._walls is not None else (_NONE2, _NONE3)
        resolve(zbuf, ids, sx, sy, rad, colors, LIGHT, MATERIAL, wz, wrgb, self.wall_alpha,
                self.traj.dim == 3, BACKGROUND, self.ss, out)
        return out
