"""Per-substep geometry: fluid-fluid and fluid-wall neighbour lists, kernel values and
gradients per edge, and the compression ψ (number density × rest volume).

The walls' share of ψ and of the pressure operator comes either from the wall particles
(Akinci et al. 2012: Σ_b V_b W_ib, Σ_b V_b ∇W_ib) or from a smooth volume map
(:mod:`dcdc.sph.volume_map`: Ψ(x_i), ∇Ψ(x_i)); with a map the fluid-wall edges are only
searched when a wall friction term needs them."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..neighbors import CellGrid, radius_search
from .volume_map import VolumeMap
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
    psi_wall: np.ndarray  # the walls' share of ψ (Σ_b V_b W_ib, or Ψ(x_i))
    wall_moment: np.ndarray | None = None  # [n, d] tangential hydrostatic moment (volume map)

    def fluid(self):
        return self.rs, self.idx, self.G

    def wall(self):
        return self.rsb, self.idxb, self.Gb


def build(x: np.ndarray, walls: np.ndarray | CellGrid, Vb: np.ndarray, h: float,
          V0: float, vmap: VolumeMap | None = None, wall_edges: bool = True) -> Neighbourhood:
    """Search neighbours within ``h`` and evaluate W, ∇W and ψ at positions ``x``.

    ``walls``: the wall particles, or (faster, as the Simulator does) a
    :class:`~dcdc.neighbors.CellGrid` of them built once with radius ``h``.
    ``vmap``: the walls as a volume map; then ψ and S_b come from it, and the fluid-wall
    edges (for wall friction) are built only if ``wall_edges``. A wall particle of the
    map counts as Ψ(x_i) · N_full neighbours for the sparse-neighbourhood test (N_full:
    neighbours of a particle inside the rest lattice)."""
    if not isinstance(walls, CellGrid):
        walls = CellGrid(walls, h)
    ff = radius_search(x, h)
    n, d = x.shape
    if vmap is None or wall_edges:
        fw = walls.search(x)
        rsb, idxb = fw.row_splits, fw.index
    else:
        rsb, idxb = np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int32)
    W, G = edge_kernels(x, x, ff.row_splits, ff.index, h)
    Wb, Gb = edge_kernels(x, walls.points, rsb, idxb, h)
    # ψ = the fluid's share + the walls' (compression sums them in separate accumulators,
    # so the split is exact to the bit)
    empty = np.zeros(n + 1, dtype=np.int64)
    psi_f = compression(ff.row_splits, W, empty, idxb[:0], Wb[:0], Vb, V0)
    if vmap is None:
        psi_b = compression(empty, W[:0], rsb, idxb, Wb, Vb, V0)
        counts = neighbour_counts(ff.row_splits, rsb)
        Sb = wall_gradient_sum(rsb, idxb, Gb, Vb, n, d)
        moment = None
    else:
        psi_b, Sb = vmap.sample(x)
        counts = np.diff(ff.row_splits) + np.rint(psi_b * full_count(h, V0, d)).astype(np.int64)
        moment = vmap.tangential_moment(x, Sb)
    return Neighbourhood(ff.row_splits, ff.index, W, G, rsb, idxb, Wb, Gb, psi_f + psi_b, counts,
                         Sb, psi_b, moment)


@lru_cache(maxsize=16)
def full_count(h: float, V0: float, dim: int) -> int:
    """Neighbours (self included) of a particle inside the rest lattice of spacing V0^(1/d)
    (cached: :func:`build` asks every substep with the same arguments)."""
    s = V0 ** (1.0 / dim)
    m = int(np.ceil(h / s))
    ax = np.arange(-m, m + 1) * s
    grids = np.meshgrid(*([ax] * dim), indexing="ij")
    r2 = sum(g ** 2 for g in grids)
    return int((r2 < h * h).sum())
