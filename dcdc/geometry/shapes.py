"""Signed distance functions of built-in shapes (negative inside the solid).

Each function returns an SDF ``f(x: [N, d]) -> [N]`` and works in 2-D and 3-D unless noted.
Combine solids with :func:`union` (min) and :func:`subtract`. :func:`cylinder_bounds` and
:func:`revolved_bounds` give the axis-aligned box of a shape (a scene without ``[domain]``
derives its domain from its shapes' boxes, ``dcdc.scene.realize.derive_domain``).
"""
from __future__ import annotations

import numpy as np


def box(lo, hi):
    """Solid axis-aligned box [lo, hi] (exact Euclidean SDF)."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    c, h = (lo + hi) / 2, (hi - lo) / 2

    def f(x):
        q = np.abs(x - c) - h
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(1), 0.0)
        return outside + inside
    return f


def container(lo, hi, open_top: bool = True, up_axis: int = 1):
    """Solid surrounding the hollow box [lo, hi]: the walls of a tank. With ``open_top`` the
    box is open along +``up_axis`` (its top face is pushed far away)."""
    hi = np.asarray(hi, dtype=np.float64).copy()
    if open_top:
        hi[up_axis] += 1e6
    inner = box(lo, hi)
    return lambda x: -inner(x)


def union(*sdfs):
    return lambda x: np.min(np.stack([f(x) for f in sdfs]), axis=0)


def subtract(a, b):
    """Solid ``a`` with solid ``b`` removed."""
    return lambda x: np.maximum(a(x), -b(x))


def intersect(*sdfs):
    """Solid common to all ``sdfs``."""
    return lambda x: np.max(np.stack([f(x) for f in sdfs]), axis=0)


def sphere(center, radius: float):
    """Solid ball (a disc in 2-D)."""
    c = np.asarray(center, dtype=np.float64)
    return lambda x: np.linalg.norm(x - c, axis=1) - radius


def cylinder(center, radius: float, height: float, axis: int = 1):
    """Solid cylinder of ``radius`` and ``height`` centred at ``center`` along ``axis``
    (0, 1, 2 = x, y, z). In 2-D its cross-section through the axis is a rectangle; a
    cylinder along z (axis 2) is a disc in 2-D."""
    c = np.asarray(center, dtype=np.float64)

    def f(x):
        d = x.shape[1]
        q = x - c[:d]
        if d == 2:
            if axis == 2:
                return np.linalg.norm(q, axis=1) - radius
            other = 1 - axis
            rad = np.abs(q[:, other])
        else:
            others = [k for k in range(3) if k != axis]
            rad = np.linalg.norm(q[:, others], axis=1)
        a = np.stack([rad - radius, np.abs(q[:, axis]) - height / 2], axis=1)
        return np.linalg.norm(np.maximum(a, 0), axis=1) + np.minimum(a.max(1), 0)
    return f


def cylinder_bounds(center, radius: float, height: float, axis: int = 1):
    """Axis-aligned bounds (lo, hi) of :func:`cylinder` in the dimension of ``center``
    (in 2-D a cylinder along z is a disc)."""
    c = np.asarray(center, dtype=np.float64)
    half = np.full(len(c), float(radius))
    if axis < len(c):
        half[axis] = height / 2
    return c - half, c + half


# ---------------------------------------------------------------- 2-D profiles, revolution
def polyline_distance(points, x2: np.ndarray) -> np.ndarray:
    """Unsigned distance from 2-D points ``x2`` [N, 2] to the polyline through ``points``."""
    p = np.asarray(points, dtype=np.float64)
    best = np.full(len(x2), np.inf)
    for a, b in zip(p[:-1], p[1:]):
        ab = b - a
        t = np.clip(((x2 - a) @ ab) / max(ab @ ab, 1e-30), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(x2 - (a + t[:, None] * ab), axis=1))
    return best


def _radial(x: np.ndarray, center, up_axis: int = 1) -> np.ndarray:
    """(distance from the vertical axis through ``center``, height) of each point. In 2-D
    the distance is |x - cx| (the cross-section through the axis)."""
    c = np.asarray(center, dtype=np.float64)[: x.shape[1]]
    q = x - c
    others = [k for k in range(x.shape[1]) if k != up_axis]
    rad = np.linalg.norm(q[:, others], axis=1)
    return np.stack([rad, q[:, up_axis]], axis=1)


def revolved_shell(profile, thickness: float, center=(0.0, 0.0, 0.0)):
    """Solid of revolution about the vertical axis through ``center``: the polyline
    ``profile`` of (radius, height) points, thickened to a wall of ``thickness``. In 2-D this
    is the cross-section through the axis (the profile mirrored about x = cx). Vessels
    (glasses, bowls, hourglasses) are built this way."""
    prof = np.asarray(profile, dtype=np.float64)
    return lambda x: polyline_distance(prof, _radial(x, center)) - thickness / 2


def revolved_bounds(profile, thickness: float, center, dim: int = 3, up_axis: int = 1):
    """Axis-aligned bounds (lo, hi) of :func:`revolved_shell` in ``dim`` dimensions: the
    profile's largest radius around the axis, its height range along ``up_axis``, both
    grown by half the wall thickness."""
    p = np.asarray(profile, dtype=np.float64)
    c = np.asarray(center, dtype=np.float64)[:dim]
    half = np.full(dim, p[:, 0].max() + thickness / 2)
    lo, hi = c - half, c + half
    lo[up_axis] = c[up_axis] + p[:, 1].min() - thickness / 2
    hi[up_axis] = c[up_axis] + p[:, 1].max() + thickness / 2
    return lo, hi


def profile_interior(profile, center=(0.0, 0.0, 0.0)):
    """Predicate: inside the cavity bounded by a vessel profile (radius r(y) of the inner
    wall, interpolated between the profile points, between its lowest and highest point)."""
    prof = np.asarray(profile, dtype=np.float64)
    order = np.argsort(prof[:, 1], kind="stable")
    ys, rs = prof[order, 1], prof[order, 0]

    def inside(x):
        ry = _radial(x, center)
        r = np.interp(ry[:, 1], ys, rs)
        return (ry[:, 0] < r) & (ry[:, 1] > ys[0]) & (ry[:, 1] < ys[-1])
    return inside


def glass_profile(bowl, stem: float, foot: float):
    """Centre-line of a stemmed glass: foot disc of radius ``foot`` at height 0, a stem of
    height ``stem`` up the axis, then the bowl's inner profile ``bowl`` [(radius, height above
    the bowl bottom)] from the axis to the rim. Returns (wall polyline, bowl inner profile),
    both as (radius, height) relative to the glass's base centre."""
    bowl = np.asarray(bowl, dtype=np.float64) + np.array([0.0, stem])
    wall = np.concatenate([[[foot, 0.0], [0.0, 0.0]], bowl], axis=0)
    return wall, bowl


def hourglass_profile(radius: float, height: float, neck: float, neck_height: float = None):
    """Inner wall of a closed hourglass of total ``height``: two cylindrical chambers of
    ``radius`` joined by conical shoulders to a neck of radius ``neck`` at mid-height.
    ``neck_height`` is the height of each conical shoulder (default radius)."""
    h = height
    s = radius if neck_height is None else neck_height
    chamber = (h - 2 * s) / 2
    return np.array([[0.0, 0.0], [radius, 0.0], [radius, chamber], [neck, chamber + s],
                     [neck, chamber + s + 1e-6], [radius, chamber + 2 * s],
                     [radius, h], [0.0, h]])


def bowl_profile(radius: float, n: int = 24):
    """Inner wall of a hemispherical bowl of ``radius`` (bottom at height 0, rim at
    ``radius``)."""
    a = np.linspace(0, np.pi / 2, n)
    return np.stack([radius * np.sin(a), radius * (1 - np.cos(a))], axis=1)


# ---------------------------------------------------------------- terrain
def terrain_height(lo, hi, base: float, slope: float, seed: int = 0, roughness: float = 0.05,
                   channels: int = 2, channel_depth: float = 0.15, channel_width: float = 0.25,
                   depressions: int = 3, depression_depth: float = 0.15,
                   depression_radius: float = 0.3):
    """Procedural heightfield y = h(x, z) over the horizontal rectangle lo..hi ([x, z]):
    a plane falling by ``slope`` (dy/dx) along +x, smooth random roughness, meandering
    ``channels`` running downhill and round ``depressions`` (basins). Deterministic in
    ``seed``. Returns ``h(x, z)`` taking arrays."""
    rng = np.random.default_rng(seed)
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    L = hi - lo
    waves = [(rng.uniform(0.5, 2.0) * 2 * np.pi / L[0], rng.uniform(0.5, 2.0) * 2 * np.pi / L[1],
              rng.uniform(0, 2 * np.pi), rng.uniform(0.3, 1.0)) for _ in range(4)]
    chans = [(rng.uniform(lo[1] + 0.3 * L[1], hi[1] - 0.3 * L[1]) if channels == 1 else
              lo[1] + (k + 0.5) * L[1] / channels, rng.uniform(0.05, 0.15) * L[1],
              rng.uniform(0.5, 1.5) * 2 * np.pi / L[0], rng.uniform(0, 2 * np.pi))
             for k in range(channels)]
    # depressions downstream of the first 30 % of the terrain, on channel lines when possible
    deps = []
    for k in range(depressions):
        px = lo[0] + L[0] * (0.35 + 0.55 * (k + rng.uniform(0.2, 0.8)) / max(depressions, 1))
        if chans:
            z0, amp, kx, ph = chans[k % len(chans)]
            pz = z0 + amp * np.sin(kx * (px - lo[0]) + ph)
        else:
            pz = rng.uniform(lo[1] + 0.2 * L[1], hi[1] - 0.2 * L[1])
        deps.append((px, pz))

    def h(x, z):
        x = np.asarray(x, dtype=np.float64)
        z = np.asarray(z, dtype=np.float64)
        y = base - slope * (x - lo[0])
        rough = sum(a * np.sin(kx * x + ph) * np.cos(kz * z + ph)
                    for kx, kz, ph, a in waves) / len(waves)
        y = y + roughness * rough
        for z0, amp, kx, ph in chans:
            zc = z0 + amp * np.sin(kx * (x - lo[0]) + ph)
            y = y - channel_depth * np.exp(-0.5 * ((z - zc) / (channel_width / 2)) ** 2)
        for px, pz in deps:
            r2 = ((x - px) ** 2 + (z - pz) ** 2) / depression_radius ** 2
            y = y - depression_depth * np.exp(-r2 * 1.5)
        return y
    return h


def heightfield(h, slice_z: float = 0.0, up_axis: int = 1):
    """Solid below the surface y = h(x, z): approximate SDF (y - h) / sqrt(1 + |∇h|²), exact
    for planes and good for gentle terrain. In 2-D the terrain is cut at z = ``slice_z``."""
    e = 1e-4

    def f(x):
        X = x[:, 0]
        Z = x[:, 2] if x.shape[1] == 3 else np.full(len(x), slice_z)
        y0 = h(X, Z)
        gx = (h(X + e, Z) - h(X - e, Z)) / (2 * e)
        gz = (h(X, Z + e) - h(X, Z - e)) / (2 * e) if x.shape[1] == 3 else 0.0
        return (x[:, up_axis] - y0) / np.sqrt(1 + gx ** 2 + gz ** 2)
    return f


# ---------------------------------------------------------------- meshes
# (dcdc.geometry.mesh; re-exported here, where they used to live)
from .mesh import load_mesh, mesh_section, mesh_section_shell, mesh_shell, mesh_solid  # noqa: E402,F401
