"""Cameras that map particle positions to pixels.

* 3-D: a pinhole (perspective) camera looking at the centre of the scene's volume from a
  direction given by azimuth (about the vertical y axis, 0 = from +z, i.e. the front view
  with x to the right) and elevation (above the horizon), placed by default at the
  smallest distance from which all eight corners of the volume's box fit into the picture.
* 2-D: an orthographic camera, x to the right and y up, fitting the domain.

Both return, per point, pixel coordinates, a depth along the view direction [m] and the
number of pixels per metre at that depth (a sphere of radius r covers ``r * ppm`` pixels).
Built-in scenes have camera presets (:data:`PRESETS`) by the scene name stored in the
trajectory's attributes; every preset field can be overridden.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import DcdcError

# scene name -> (azimuth deg, elevation deg) of a good 3-D view of that showcase
PRESETS: dict[str, tuple[float, float]] = {
    "cocktail": (-30.0, 25.0),
    "hourglass": (-25.0, 15.0),
    "canyon": (-40.0, 35.0),
    "dam_break": (-35.0, 25.0),
    "double_dam_break": (-30.0, 30.0),
    "lock_exchange": (-25.0, 20.0),
    "rayleigh_taylor": (-30.0, 20.0),
}
DEFAULT_VIEW = (-35.0, 25.0)
FOV_DEG = 35.0  # vertical field of view
MARGIN = 1.04   # the fitted box leaves this much room around itself


@dataclass(frozen=True)
class Camera:
    """``width`` x ``height`` pixels. Perspective when ``dim == 3`` (``eye`` looking at
    ``target``), orthographic when ``dim == 2`` (``target`` at the centre, ``scale`` pixels
    per metre)."""

    dim: int
    width: int
    height: int
    target: tuple
    eye: tuple = (0.0, 0.0, 1.0)
    scale: float = 1.0
    fov_deg: float = FOV_DEG

    @property
    def focal(self) -> float:
        """Focal length in pixels (perspective)."""
        return 0.5 * self.height / np.tan(np.radians(self.fov_deg) / 2)

    def basis(self):
        """Right, up and forward unit vectors of the perspective camera."""
        f = np.subtract(self.target, self.eye).astype(np.float64)
        f /= np.linalg.norm(f)
        up = np.array([0.0, 1.0, 0.0])
        if abs(f @ up) > 0.999:  # looking straight down or up
            up = np.array([0.0, 0.0, -1.0])
        r = np.cross(f, up)
        r /= np.linalg.norm(r)
        return r, np.cross(r, f), f

    def project(self, x: np.ndarray):
        """Pixel x, pixel y (down), depth [m] and pixels per metre of points ``x`` [N, dim]."""
        x = np.asarray(x, dtype=np.float64)
        if self.dim == 2:
            sx = 0.5 * self.width + self.scale * (x[:, 0] - self.target[0])
            sy = 0.5 * self.height - self.scale * (x[:, 1] - self.target[1])
            return sx, sy, np.zeros(len(x)), np.full(len(x), self.scale)
        r, u, f = self.basis()
        d = x - np.asarray(self.eye)
        xc, yc, zc = d @ r, d @ u, d @ f
        zc = np.maximum(zc, 1e-6)
        ppm = self.focal / zc
        return 0.5 * self.width + xc * ppm, 0.5 * self.height - yc * ppm, zc, ppm

    def pixels_per_metre_at_target(self) -> float:
        """Scale at the view centre (what a scale bar in the picture means in 3-D)."""
        if self.dim == 2:
            return self.scale
        return self.focal / float(np.linalg.norm(np.subtract(self.target, self.eye)))

    def faces_camera(self, x: np.ndarray, n: np.ndarray) -> np.ndarray:
        """True where a surface at ``x`` with normal ``n`` (into the fluid) faces the camera:
        walls behind and below the fluid. The other walls would hide the fluid (the cut-away)."""
        if self.dim == 2:
            return np.ones(len(x), bool)
        return np.einsum("ij,ij->i", np.asarray(self.eye) - x, n) > 0


def view_direction(azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector from the target to the eye."""
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([np.sin(a) * np.cos(e), np.sin(e), np.cos(a) * np.cos(e)])


def fit_camera(lo, hi, width: int, height: int | None = None, scene: str | None = None,
               azimuth: float | None = None, elevation: float | None = None,
               distance: float | None = None, zoom: float = 1.0) -> Camera:
    """A camera that shows the box [lo, hi] whole. 2-D: ``height`` defaults to the box's
    aspect ratio. 3-D: view direction from the scene's preset unless given; ``distance``
    [m] from the box centre defaults to the smallest one at which all corners are inside the
    picture; ``zoom`` > 1 moves closer (3-D) or magnifies (2-D)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    if zoom <= 0:
        raise DcdcError(f"zoom must be > 0 (got {zoom})")
    centre = 0.5 * (lo + hi)
    if len(lo) == 2:
        if azimuth is not None or elevation is not None or distance is not None:
            raise DcdcError("--azimuth/--elevation/--distance apply to 3-D trajectories only")
        span = np.maximum(hi - lo, 1e-9)
        if height is None:
            height = int(round(width * span[1] / span[0]))
            height = int(np.clip(height, 64, 4 * width))
        scale = zoom * min(width / span[0], height / span[1]) / MARGIN
        return Camera(2, _even(width), _even(height), tuple(centre), scale=scale)
    az0, el0 = PRESETS.get(scene or "", DEFAULT_VIEW)
    az = az0 if azimuth is None else azimuth
    el = el0 if elevation is None else elevation
    if not -90 <= el <= 90:
        raise DcdcError(f"elevation must be within [-90, 90] degrees (got {el})")
    direction = view_direction(az, el)
    if height is None:  # the picture takes the shape of the box as seen from there
        trial = Camera(3, 1000, 1000, tuple(centre), tuple(centre + direction))
        trial = replace(trial, eye=tuple(centre + _fit_distance(trial, lo, hi) * direction))
        sx, sy, _, _ = trial.project(_corners(lo, hi))
        aspect = (sy.max() - sy.min()) / max(sx.max() - sx.min(), 1e-9)
        height = int(round(width * float(np.clip(aspect, 0.5, 2.0))))
    cam = Camera(3, _even(width), _even(height), tuple(centre), tuple(centre + direction))
    if distance is None:
        distance = _fit_distance(cam, lo, hi) / zoom
    elif distance <= 0:
        raise DcdcError(f"distance must be > 0 (got {distance})")
    return replace(cam, eye=tuple(centre + distance * direction))


def _fit_distance(cam: Camera, lo, hi) -> float:
    """Smallest eye distance from the target at which every box corner projects inside."""
    r, u, f = cam.basis()
    corners = _corners(lo, hi) - np.asarray(cam.target)
    tan_v = 0.5 * cam.height / cam.focal
    tan_h = tan_v * cam.width / cam.height
    # corner at depth d + c.f must satisfy |c.r| <= tan_h (d + c.f), |c.u| <= tan_v (d + c.f)
    need = np.maximum(np.abs(corners @ r) / tan_h, np.abs(corners @ u) / tan_v) - corners @ f
    return MARGIN * float(need.max())


def _corners(lo, hi) -> np.ndarray:
    return np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1])
                     for c in (lo[2], hi[2])], np.float64)


def _even(n) -> int:
    """Video encoders want even frame sizes."""
    n = int(n)
    return max(2, n + (n % 2))
