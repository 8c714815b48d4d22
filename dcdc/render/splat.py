"""Sphere impostors splatted into a z-buffer (the rasteriser behind ``dcdc render``).

Each particle is drawn as the screen disc of a sphere: for a pixel at normalised offset
(dx, dy) inside the disc the sphere's surface normal is (dx, -dy, sqrt(1 - dx² - dy²)) in
camera space, its depth is the centre's depth minus the sphere's radius times that z
component, and the pixel keeps the nearest surface (a z-buffer, so the drawing order does
not matter and intersecting spheres cut each other correctly). Shading is Blinn–Phong with
one light from the upper left of the viewer plus ambient light. One pass over the
particles, each touching only the pixels of its own disc: O(N r²).
"""
from __future__ import annotations

import numpy as np
from numba import njit

# light direction in camera space (x right, y up, z towards the viewer), normalised
_L = np.array([-0.45, 0.6, 0.66])
LIGHT = _L / np.linalg.norm(_L)
AMBIENT, DIFFUSE, SPECULAR, SHININESS = 0.38, 0.62, 0.28, 32.0
MIN_RADIUS_PX = 0.75  # far or tiny particles stay visible


@njit(cache=True, nogil=True)
def splat_spheres(sx, sy, depth, rad_px, rad_m, colors, zbuf, rgb, light, ambient, diffuse,
                  specular, shininess, min_radius):
    """Draw spheres centred at pixel (sx, sy) with depth ``depth`` [m], screen radius
    ``rad_px`` and world radius ``rad_m`` into ``zbuf`` [H, W] and ``rgb`` [H, W, 3]
    (both updated in place), colour ``colors[i]`` (RGB in [0, 1])."""
    H, W = zbuf.shape
    lx, ly, lz = light[0], light[1], light[2]
    # Blinn half vector between the light and the viewer (0, 0, 1)
    hx, hy, hz = lx, ly, lz + 1.0
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / hn, hy / hn, hz / hn
    for i in range(sx.shape[0]):
        r = max(rad_px[i], min_radius)
        cx, cy = sx[i], sy[i]
        x0 = max(int(np.floor(cx - r)), 0)
        x1 = min(int(np.ceil(cx + r)), W - 1)
        y0 = max(int(np.floor(cy - r)), 0)
        y1 = min(int(np.ceil(cy + r)), H - 1)
        if x0 > x1 or y0 > y1:
            continue
        inv = 1.0 / r
        for py in range(y0, y1 + 1):
            dy = (py + 0.5 - cy) * inv
            for px in range(x0, x1 + 1):
                dx = (px + 0.5 - cx) * inv
                q = dx * dx + dy * dy
                if q >= 1.0:
                    continue
                nz = np.sqrt(1.0 - q)
                d = depth[i] - rad_m[i] * nz
                if d >= zbuf[py, px]:
                    continue
                zbuf[py, px] = d
                ny = -dy
                lam = max(dx * lx + ny * ly + nz * lz, 0.0)
                spec = max(dx * hx + ny * hy + nz * hz, 0.0) ** shininess
                shade = ambient + diffuse * lam
                for c in range(3):
                    v = colors[i, c] * shade + specular * spec
                    rgb[py, px, c] = min(v, 1.0)


def splat(sx, sy, depth, rad_px, rad_m, colors, zbuf, rgb) -> None:
    """:func:`splat_spheres` with the default light and material."""
    n = len(sx)
    if n == 0:
        return
    f = np.float64
    splat_spheres(np.asarray(sx, f), np.asarray(sy, f), np.asarray(depth, f),
                  np.broadcast_to(np.asarray(rad_px, f), (n,)).copy(),
                  np.broadcast_to(np.asarray(rad_m, f), (n,)).copy(),
                  np.ascontiguousarray(np.broadcast_to(colors, (n, 3)), f), zbuf, rgb, LIGHT,
                  AMBIENT, DIFFUSE, SPECULAR, SHININESS, MIN_RADIUS_PX)


@njit(cache=True, nogil=True)
def resolve(zbuf, rgb, wall_z, wall_rgb, wall_alpha, walls_over_fluid, background, ss, out):
    """Composite and box-filter a supersampled frame into ``out`` (uint8 [H, W, 3]).

    A pixel shows the fluid surface, or the background where there is none; a wall surface
    nearer than that (``wall_z`` < ``zbuf``) veils it with opacity ``wall_alpha``, when
    ``walls_over_fluid`` (3-D) also over fluid, else (2-D, fluid on top) only the
    background. ``ss`` x ``ss`` samples are averaged per output pixel."""
    H, W = out.shape[0], out.shape[1]
    norm = 1.0 / (ss * ss)
    has_walls = wall_z.shape[0] > 0
    for y in range(H):
        for x in range(W):
            acc0 = 0.0
            acc1 = 0.0
            acc2 = 0.0
            for j in range(ss):
                for i in range(ss):
                    py, px = y * ss + j, x * ss + i
                    fluid = zbuf[py, px] < np.inf
                    if fluid:
                        c0, c1, c2 = rgb[py, px, 0], rgb[py, px, 1], rgb[py, px, 2]
                    else:
                        c0, c1, c2 = background[0], background[1], background[2]
                    if has_walls and wall_z[py, px] < zbuf[py, px] and \
                            (walls_over_fluid or not fluid):
                        a = wall_alpha
                        c0 = (1 - a) * c0 + a * wall_rgb[py, px, 0]
                        c1 = (1 - a) * c1 + a * wall_rgb[py, px, 1]
                        c2 = (1 - a) * c2 + a * wall_rgb[py, px, 2]
                    acc0 += c0
                    acc1 += c1
                    acc2 += c2
            out[y, x, 0] = np.uint8(min(max(acc0 * norm, 0.0), 1.0) * 255 + 0.5)
            out[y, x, 1] = np.uint8(min(max(acc1 * norm, 0.0), 1.0) * 255 + 0.5)
            out[y, x, 2] = np.uint8(min(max(acc2 * norm, 0.0), 1.0) * 255 + 0.5)
