"""Sphere impostors splatted into a z-buffer (the rasteriser behind ``dcdc render``).

References: depth-corrected sphere impostors as in Gumhold, "Splatting illuminated
ellipsoids with depth correction" (VMV 2003) and molecular viewers since; Blinn, "Models
of light reflection for computer synthesized pictures" (SIGGRAPH 1977) for the shading;
perspective-correct depth of triangles from 1/z being linear in screen space (Heckbert &
Moreton, "Interpolation for polygon texture mapping and shading", 1991).

Each particle is drawn as the screen disc of a sphere: for a sample at normalised offset
(dx, dy) inside the disc the sphere's surface normal is (dx, -dy, sqrt(1 - dx² - dy²)) in
camera space, its depth is the centre's depth minus the sphere's radius times that z
component, and the sample keeps the nearest surface (a z-buffer, so the drawing order does
not matter and intersecting spheres cut each other correctly). Shading is deferred: the
splat pass stores only depth and particle index per sample, and :func:`resolve` shades the
visible sample once (Blinn–Phong with shininess 32, one light from the upper left of the viewer plus ambient
light), composites the faint wall layer and box-filters the supersampled image down.
Spheres are splatted nearest first, so most hidden samples of the spheres behind are
rejected by one comparison. Cost: O(N r²) comparisons plus O(pixels) shading.
"""
from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, prange

# light direction in camera space (x right, y up, z towards the viewer), normalised
_L = np.array([-0.45, 0.6, 0.66])
LIGHT = _L / np.linalg.norm(_L)
MATERIAL = np.array([0.38, 0.62, 0.28])  # ambient, diffuse, specular (shininess 32)
MIN_RADIUS_PX = 0.75  # far or tiny particles stay visible


@njit(cache=True, nogil=True, parallel=True)
def splat_ids(sx, sy, depth, rad_px, rad_m, zbuf, ids, bands):
    """Write the index of the nearest sphere surface into ``ids`` [H, W] (``zbuf``: its
    depth [m]; both updated in place). Spheres centred at pixel (sx, sy) with depth
    ``depth``, screen radius ``rad_px`` (at least :data:`MIN_RADIUS_PX`), world radius
    ``rad_m``; pixel centres at +0.5. The image is split into ``bands`` horizontal bands
    drawn in parallel, each by one thread visiting the spheres in the given order, so the
    result does not depend on ``bands``."""
    H, W = zbuf.shape
    for b in prange(bands):
        r0 = b * H // bands
        r1 = (b + 1) * H // bands - 1
        for i in range(sx.shape[0]):
            r = max(rad_px[i], MIN_RADIUS_PX)
            cx, cy = sx[i], sy[i]
            x0 = max(int(np.floor(cx - r)), 0)
            x1 = min(int(np.ceil(cx + r)), W - 1)
            y0 = max(int(np.floor(cy - r)), r0)
            y1 = min(int(np.ceil(cy + r)), r1)
            if x0 > x1 or y0 > y1:
                continue
            inv = 1.0 / r
            front = depth[i] - rad_m[i]  # the sphere's nearest point
            for py in range(y0, y1 + 1):
                dy = (py + 0.5 - cy) * inv
                for px in range(x0, x1 + 1):
                    if zbuf[py, px] <= front:  # hidden at this pixel whatever its offset
                        continue
                    dx = (px + 0.5 - cx) * inv
                    q = dx * dx + dy * dy
                    if q >= 1.0:
                        continue
                    d = depth[i] - rad_m[i] * np.sqrt(1.0 - q)
                    if d < zbuf[py, px]:
                        zbuf[py, px] = d
                        ids[py, px] = i


@njit(cache=True, nogil=True)
def splat_triangles(px, py, pz, tris, shade, color, zbuf, rgb, bias):
    """Rasterise triangles (vertex pixel coordinates ``px``, ``py``, view depth ``pz`` > 0,
    vertex indices ``tris`` [F, 3]) flat-shaded ``color * shade[f]`` into ``zbuf``/``rgb``
    (nearest surface wins). Samples at pixel centres inside the triangle (either winding;
    edges shared by two triangles are filled by both); depth interpolated perspective-
    correctly (1/z is linear in screen space), then moved ``bias`` [m] towards the camera
    (so a surface wins over spheres that poke through it by less). Triangles reaching
    behind the camera are skipped."""
    H, W = zbuf.shape
    for f in range(tris.shape[0]):
        a, b, c = tris[f, 0], tris[f, 1], tris[f, 2]
        if pz[a] <= 1e-6 or pz[b] <= 1e-6 or pz[c] <= 1e-6:
            continue
        ax, ay, bx, by, cx, cy = px[a], py[a], px[b], py[b], px[c], py[c]
        area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if area == 0.0:
            continue
        x0 = max(int(np.floor(min(ax, bx, cx))), 0)
        x1 = min(int(np.ceil(max(ax, bx, cx))), W - 1)
        y0 = max(int(np.floor(min(ay, by, cy))), 0)
        y1 = min(int(np.ceil(max(ay, by, cy))), H - 1)
        ia, ib, ic = 1.0 / pz[a], 1.0 / pz[b], 1.0 / pz[c]
        for yy in range(y0, y1 + 1):
            sy = yy + 0.5
            for xx in range(x0, x1 + 1):
                sx = xx + 0.5
                wa = ((bx - sx) * (cy - sy) - (by - sy) * (cx - sx)) / area
                wb = ((cx - sx) * (ay - sy) - (cy - sy) * (ax - sx)) / area
                wc = 1.0 - wa - wb
                if wa < 0.0 or wb < 0.0 or wc < 0.0:
                    continue
                d = 1.0 / (wa * ia + wb * ib + wc * ic) - bias
                if d < zbuf[yy, xx]:
                    zbuf[yy, xx] = d
                    for k in range(3):
                        rgb[yy, xx, k] = min(color[k] * shade[f], 1.0)


@njit(cache=True, nogil=True, inline="always")
def _lighting(px, py, i, sx, sy, rad_px, light, material):
    """(diffuse factor, specular term) of sphere ``i`` at sample (px, py)."""
    r = max(rad_px[i], MIN_RADIUS_PX)
    dx = (px + 0.5 - sx[i]) / r
    dy = -(py + 0.5 - sy[i]) / r
    nz = np.sqrt(max(1.0 - dx * dx - dy * dy, 0.0))
    lx, ly, lz = light[0], light[1], light[2]
    hx, hy, hz = lx, ly, lz + 1.0  # Blinn half vector (viewer along +z)
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    lam = max(dx * lx + dy * ly + nz * lz, 0.0)
    h = max((dx * hx + dy * hy + nz * hz) / hn, 0.0)
    h *= h
    h *= h
    h *= h
    h *= h
    h *= h  # h^32: the shininess, by five squarings (a pow() costs more than the rest)
    return material[0] + material[1] * lam, material[2] * h


@njit(cache=True, nogil=True)
def shade_layer(ids, sx, sy, rad_px, colors, light, material, rgb):
    """Shade every covered sample of one layer into ``rgb`` [H, W, 3] (e.g. the walls)."""
    H, W = ids.shape
    for py in range(H):
        for px in range(W):
            i = ids[py, px]
            if i >= 0:
                diff, spec = _lighting(px, py, i, sx, sy, rad_px, light, material)
                for c in range(3):
                    rgb[py, px, c] = min(colors[i, c] * diff + spec, 1.0)


@njit(cache=True, nogil=True, parallel=True)
def resolve(zbuf, ids, sx, sy, rad_px, colors, light, material, wall_z, wall_rgb, wall_alpha,
            walls_over_fluid, background, ss, out):
    """Shade, composite and box-filter a supersampled frame into ``out`` (uint8 [H, W, 3]).

    A sample shows its fluid sphere, or the background where there is none; a wall surface
    nearer than that (``wall_z`` < ``zbuf``) veils it with opacity ``wall_alpha``, when
    ``walls_over_fluid`` (3-D) also over fluid, else (2-D, fluid on top) only the
    background. ``ss`` x ``ss`` samples are averaged per output pixel; rows in parallel."""
    H, W = out.shape[0], out.shape[1]
    norm = 1.0 / (ss * ss)
    has_walls = wall_z.shape[0] > 0
    for y in prange(H):
        for x in range(W):
            acc0 = 0.0
            acc1 = 0.0
            acc2 = 0.0
            for j in range(ss):
                for i in range(ss):
                    py, px = y * ss + j, x * ss + i
                    k = ids[py, px]
                    fluid = k >= 0
                    if fluid:
                        diff, spec = _lighting(px, py, k, sx, sy, rad_px, light, material)
                        c0 = min(colors[k, 0] * diff + spec, 1.0)
                        c1 = min(colors[k, 1] * diff + spec, 1.0)
                        c2 = min(colors[k, 2] * diff + spec, 1.0)
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


@njit(cache=True, nogil=True, parallel=True)
def clear(zbuf, ids):
    """Empty a z-buffer (+inf) and its index buffer (-1), rows in parallel."""
    for y in prange(zbuf.shape[0]):
        for x in range(zbuf.shape[1]):
            zbuf[y, x] = np.inf
            ids[y, x] = -1


def splat(sx, sy, depth, rad_px, rad_m, zbuf, ids, bands: int | None = None):
    """:func:`splat_ids` of N spheres, nearest first; returns the per-sphere arrays in the
    order that ``ids`` refers to: (sx, sy, rad_px, order)."""
    n = len(sx)
    f = np.float64
    order = np.argsort(depth, kind="stable")
    pick = lambda a: np.ascontiguousarray(np.broadcast_to(np.asarray(a, f), (n,))[order])
    sx, sy, rad_px = pick(sx), pick(sy), pick(rad_px)
    if n:
        splat_ids(sx, sy, pick(depth), rad_px, pick(rad_m), zbuf, ids, bands or get_num_threads())
    return sx, sy, rad_px, order
