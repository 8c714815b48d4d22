"""Rigid walls as boundary particles (Akinci, Ihmsen, Akinci, Solenthaler & Teschner 2012,
"Versatile rigid-fluid coupling for incompressible SPH", eq. 4-5).

A wall particle ``b`` stands for the volume ``V_b = 1 / Σ_k W_bk`` (sum over the wall
particles ``k`` of the same sampling, ``b`` included): densely sampled regions get smaller
volumes, so an irregular or multi-layer sampling contributes the right amount to a fluid
particle's density estimate. Wall particles come from :func:`dcdc.geometry.sample_walls`.
"""
from __future__ import annotations

import numpy as np

from ..errors import DcdcError
from ..neighbors import radius_search
from .terms import compression, edge_kernels


def wall_volumes(wall_x: np.ndarray, h: float, V0: float | None = None) -> np.ndarray:
    """Akinci volumes V_b = 1 / Σ_k W(x_b - x_k) over wall particles (self included).

    With ``V0`` (the fluid particles' rest volume) the volumes are capped at ``V0``: a wall
    sampled in several layers at the fluid spacing (:func:`dcdc.geometry.sample_walls`) has
    V_b = V0 inside its shell, but its face towards the fluid misses half its neighbours and
    Akinci's estimate grows there by up to 40 %, which would push resting fluid off the wall
    (ψ = 1.03-1.05 next to it instead of 1.00).
    """
    if len(wall_x) == 0:
        return np.zeros(0)
    nb = radius_search(wall_x, h)
    W, _ = edge_kernels(wall_x, wall_x, nb.row_splits, nb.index, h)
    empty = np.zeros(len(wall_x) + 1, dtype=np.int64)
    one = compression(nb.row_splits, W, empty, np.zeros(0, np.int32), np.zeros(0), np.zeros(0), 1.0)
    vol = 1.0 / one
    return vol if V0 is None else np.minimum(vol, V0)


def check_fluid_outside_walls(x: np.ndarray, wall_x: np.ndarray, wall_n: np.ndarray,
                              spacing: float) -> None:
    """Raise a one-line :class:`DcdcError` if a fluid particle sits inside a wall: closer than
    a quarter spacing to a wall particle, or behind one of the wall particles within a
    spacing (on the solid side of it: ``(x - x_b)·n_b < -spacing/4``, normals point into
    the fluid). Fluid sampled on the lattice one spacing from the wall passes."""
    if len(x) == 0 or len(wall_x) == 0:
        return
    nb = radius_search(x, spacing * (1 + 1e-6), wall_x)
    if nb.n_edges == 0:
        return
    recv = nb.receivers()
    off = x[recv] - wall_x[nb.index]
    dist = np.linalg.norm(off, axis=1)
    side = np.einsum("ij,ij->i", off, wall_n[nb.index])
    bad_edge = (dist < 0.25 * spacing) | (side < -0.25 * spacing)
    if bad_edge.any():
        bad = np.unique(recv[bad_edge])
        i = int(bad[0])
        raise DcdcError(f"{len(bad)} fluid particle(s) start inside a wall, "
                        f"e.g. #{i} at {np.round(x[i], 4).tolist()}")
