"""Per-substep geometry: fluid-fluid and fluid-wall neighbour lists, kernel values and
gradients per edge, and the compression ψ (number density × rest volume)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..neighbors import CellGrid, radius_search
from .terms import compression, edge_kernels, neighbour_counts, wall_gradient_sum


@dataclass
class Neighbourhood:
    rs: np.ndarray  # fluid-fluid CSR (self included)
    idx: np.ndarray
    W: np.ndarray
    G: np.ndarray
    rsb: np.ndarray  # fluid-wall CSR
    idxb: np.ndarray
    Wb: np.ndarray
    Gb: np.ndarray
    psi: np.ndarray  # ρ_i / ρ0_i
    counts: np.ndarray  # fluid + wall neighbours
    Sb: np.ndarray  # [n, d] Σ_b V_b ∇W_ib, the walls' part of the pressure operator

    def fluid(self):
        return self.rs, self.idx, self.G

    def wall(self):
        return self.rsb, self.idxb, self.Gb


def build(x: np.ndarray, walls: np.ndarray | CellGrid, Vb: np.ndarray, h: float,
          V0: float) -> Neighbourhood:
    """Search neighbours within ``h`` and evaluate W, ∇W and ψ at positions ``x``.

    ``walls``: the wall particles, or (faster, as the Simulator does) a
    :class:`~dcdc.neighbors.CellGrid` of them built once with radius ``h``."""
    if not isinstance(walls, CellGrid):
        walls = CellGrid(walls, h)
    ff = radius_search(x, h)
    fw = walls.search(x)
    W, G = edge_kernels(x, x, ff.row_splits, ff.index, h)
    Wb, Gb = edge_kernels(x, walls.points, fw.row_splits, fw.index, h)
    psi = compression(ff.row_splits, W, fw.row_splits, fw.index, Wb, Vb, V0)
    counts = neighbour_counts(ff.row_splits, fw.row_splits)
    Sb = wall_gradient_sum(fw.row_splits, fw.index, Gb, Vb, len(x), x.shape[1])
    return Neighbourhood(ff.row_splits, ff.index, W, G, fw.row_splits, fw.index, Wb, Gb, psi,
                         counts, Sb)
