"""CConv layers as torch modules: plain, density-conditioned, antisymmetric.

* :class:`CConvLayer` — eq. 3 with Γ = identity (Ummenhofer et al. 2020), filter + bias.
* :class:`DensityCConvLayer` — eq. 3 with Γ_ij = γ_ij ⊙ f_j + β_ij (eqs. 4–5).
* :class:`AntisymCConvLayer` — the momentum-conserving layer of Prantl et al. 2022 (DMCF):
  an odd filter g(−u) = −g(u) applied to symmetric pair features, so the pair terms
  t_ij = g(Λ(x_j − x_i))ᵀ Γˢ_ij satisfy t_ij = −t_ji and Σ_i Σ_j t_ij = 0.
"""
from __future__ import annotations

import numpy as np
import torch
from torch import nn

from .cconv import ConvGeometry, cconv
from .modulation import DensityEmbedding, DensityPlan, PairModulation


class CConvLayer(nn.Module):
    """Continuous convolution with a K^d filter [K^d, C_in, C_out] and a bias."""

    def __init__(self, in_channels: int, out_channels: int, dim: int, kernel_size: int = 4,
                 bias: bool = True):
        super().__init__()
        self.dim, self.kernel_size = dim, kernel_size
        self.in_channels, self.out_channels = in_channels, out_channels
        n = kernel_size ** dim
        w = torch.empty(n, in_channels, out_channels)
        # Xavier-uniform over the whole filter, as DeepLagrangianFluids initialises its convs
        bound = float(np.sqrt(6.0 / (n * in_channels + out_channels)))
        nn.init.uniform_(w, -bound, bound)
        self.weight = nn.Parameter(w)
        self.bias = nn.Parameter(torch.zeros(out_channels)) if bias else None
        self.backend = "auto"
        self.gemm_dtype: torch.dtype | None = None

    def filter(self) -> torch.Tensor:
        return self.weight

    def conv(self, rows: torch.Tensor, geom: ConvGeometry) -> torch.Tensor:
        out = cconv(rows, self.filter(), geom, self.backend, self.gemm_dtype)
        return out if self.bias is None else out + self.bias

    def forward(self, features: torch.Tensor, geom: ConvGeometry) -> torch.Tensor:
        return self.conv(features, geom)


class DensityCConvLayer(CConvLayer):
    """Density-conditioned dynamic convolution (eqs. 3–5)."""

    def __init__(self, in_channels: int, out_channels: int, dim: int, kernel_size: int = 4,
                 embed_dim: int = 8, hidden: int = 32, bias: bool = True):
        super().__init__(in_channels, out_channels, dim, kernel_size, bias)
        self.modulation = PairModulation(embed_dim, in_channels, hidden)

    def forward(self, features: torch.Tensor, geom: ConvGeometry, plan: DensityPlan,
                embedding: DensityEmbedding) -> torch.Tensor:
        rows, vgeom = plan.modulated(features, self.modulation, embedding)
        return self.conv(rows, vgeom)


def mirror_cells(kernel_size: int, dim: int) -> torch.Tensor:
    """Index of the cell at the point-reflected position u → −u (x-fastest layout)."""
    k = np.arange(kernel_size)
    grids = np.meshgrid(*([k] * dim), indexing="ij")  # grids[a] is axis a
    idx = sum((kernel_size - 1 - grids[a]) * kernel_size ** a for a in range(dim))
    order = sum(grids[a] * kernel_size ** a for a in range(dim))
    mirror = np.empty(kernel_size ** dim, dtype=np.int64)
    mirror[order.ravel()] = idx.ravel()
    return torch.from_numpy(mirror)


class AntisymCConvLayer(CConvLayer):
    """Antisymmetric continuous convolution (Prantl et al. 2022), no bias.

    The filter is W_c − W_{mirror(c)}: Λ is odd and the align-corners interpolation maps
    −u to the mirrored cells, so g(−u) = −g(u). Pair features Γˢ_ij (density-conditioned
    with a symmetric modulation, or plain f_i + f_j) are symmetric, hence t_ij = −t_ji on
    a symmetric neighbour list (same radius, no normalisation, self excluded).
    """

    def __init__(self, in_channels: int, out_channels: int, dim: int, kernel_size: int = 4,
                 embed_dim: int = 8, hidden: int = 32, conditioned: bool = True):
        super().__init__(in_channels, out_channels, dim, kernel_size, bias=False)
        self.register_buffer("mirror", mirror_cells(kernel_size, dim), persistent=False)
        self.modulation = (PairModulation(embed_dim, in_channels, hidden, symmetric=True)
                           if conditioned else None)

    def filter(self) -> torch.Tensor:
        return self.weight - self.weight[self.mirror]

    def forward(self, features: torch.Tensor, geom: ConvGeometry, plan: DensityPlan,
                embedding: DensityEmbedding | None = None) -> torch.Tensor:
        if self.modulation is None:
            return self.conv(*plan.plain_symmetric_edges(features))
        if plan.mode == "classes":
            # exact split of the per-edge sum, without E × C rows (see DensityPlan.symmetric_split)
            rows, pgeom, h, S = plan.symmetric_split(features, self.modulation, embedding)
            W = self.filter()  # [cells, C_in, C_out]
            n, P, cin = h.shape
            hw = (h.reshape(n * P, cin) @ W.permute(1, 0, 2).reshape(cin, -1))
            hw = hw.reshape(n, P, W.shape[0], W.shape[2])
            self_term = torch.einsum("icb,ibco->io", S, hw)
            return self.conv(rows, pgeom) + self_term
        rows, egeom = plan.symmetric_edges(features, self.modulation, embedding)
        return self.conv(rows, egeom)
