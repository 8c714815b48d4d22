"""Nozzle emitters (``shape = "nozzle"``, round, and ``"box"``, rectangular): the points of
one layer across the jet and the layers released at the jet's speed or rate."""
from __future__ import annotations

import math

import numpy as np


def nozzle_ticks(length: float, spacing: float) -> np.ndarray:
    """Offsets of the points across one side of a box nozzle: floor(length / spacing) of
    them (at least one), ``spacing`` apart and centred, as in a box block of that size."""
    n = max(1, int(math.floor(length / spacing + 1e-9)))
    return (np.arange(n) - 0.5 * (n - 1)) * spacing


def box_nozzle_axes(direction, up=None):
    """(height axis, width axis) of a 3-D box nozzle jetting along ``direction``: ``up``
    (default y, or x for a vertical jet) made normal to the jet, and direction × height."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    if up is None:
        up = [1.0, 0.0, 0.0] if abs(d[1]) > 1 - 1e-6 else [0.0, 1.0, 0.0]
    h = np.asarray(up, dtype=np.float64)
    h = h - (h @ d) * d
    h /= np.linalg.norm(h)
    return h, np.cross(d, h)


def nozzle_layer(e: dict, dim: int, spacing: float) -> np.ndarray:
    """One layer of a nozzle's particles around ``position``, across the jet: a round
    nozzle's disc (a segment in 2-D) of points k·spacing from the centre within
    ``radius``; a box nozzle's width × height grid (in 2-D: the segment of its height)."""
    d = np.asarray(e["direction"], dtype=np.float64)
    d /= np.linalg.norm(d)
    if e.get("shape", "nozzle") == "box":
        if dim == 2:
            disc = nozzle_ticks(e["height"], spacing)[:, None] * np.array([-d[1], d[0]])[None]
        else:
            h, w = box_nozzle_axes(d, e.get("up"))
            a, b = np.meshgrid(nozzle_ticks(e["width"], spacing), nozzle_ticks(e["height"], spacing),
                               indexing="ij")
            disc = a.reshape(-1, 1) * w[None] + b.reshape(-1, 1) * h[None]
        return np.asarray(e["position"]) + disc
    r = e.get("radius") if e.get("radius") is not None else 2 * spacing
    # orthonormal basis of the plane normal to d
    a = np.eye(dim)[np.argmin(np.abs(d))]
    u = a - (a @ d) * d
    u /= np.linalg.norm(u)
    n = int(np.floor(r / spacing + 1e-9))
    ks = np.arange(-n, n + 1) * spacing
    if dim == 2:
        disc = ks[:, None] * u[None]
    else:
        w = np.cross(d, u)
        g = np.stack(np.meshgrid(ks, ks, indexing="ij"), -1).reshape(-1, 2)
        g = g[np.linalg.norm(g, axis=1) <= r + 1e-9]
        disc = g[:, :1] * u[None] + g[:, 1:] * w[None]
    return np.asarray(e["position"]) + disc


def nozzle_points(e: dict, dim: int, spacing: float):
    """Nozzle cross-section points (:func:`nozzle_layer`) repeated in layers: positions,
    velocities and birth times."""
    d = np.asarray(e["direction"], dtype=np.float64)
    d /= np.linalg.norm(d)
    pos = nozzle_layer(e, dim, spacing)
    per_layer = len(pos)
    interval = spacing / e["speed"] if e["rate"] is None else per_layer / e["rate"]
    n_layers = int(np.ceil((e["stop"] - e["start"]) / interval - 1e-9))
    births = e["start"] + interval * np.arange(n_layers)
    x = np.tile(pos, (n_layers, 1))
    b = np.repeat(births, per_layer)
    v = np.tile(e["speed"] * d, (len(x), 1))
    return x, v, b
