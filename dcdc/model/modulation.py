"""Density-conditioned modulation Γ_ij = γ_ij ⊙ f_j + β_ij (paper eqs. 3–5, 7).

* Embedding (eq. 4): e_i = φ(log(1 + ρ_i / ρ_ref)), φ a small ReLU MLP R → R^{d_e}.
* Pair modulation (eq. 5), made the identity at ρ_i = ρ_j = ρ_ref *by construction* (eq. 7)::

      γ_ij = 2 σ(g(e_i ⊕ e_j) − g(e_ref ⊕ e_ref))      → 2σ(0) = 1 at the reference
      β_ij =     b(e_i ⊕ e_j) − b(e_ref ⊕ e_ref)       → 0        at the reference

  with g, b small MLPs (the paper's W_γ, W_β) and e_ref = φ(log 2). The paper's plain
  σ(W_γ[·]) lies in (0, 1) and cannot equal 1, so eq. 7 could only hold approximately; the
  factor 2 and the reference offsets make it exact for any weights, so a dcdc network with
  all densities at ρ_ref *is* a plain CConv network (tested).
* β is added per edge, so it contributes β_ij · Σ_c G_c w — it is part of the feature row
  the convolution reads, never a per-receiver bias, which keeps it exact.

Two ways to evaluate Γ over the edges of a step (:class:`DensityPlan`):

* ``"classes"`` (fast path): a scene has few distinct densities P. γ, β depend only on the
  (receiver class, sender class) pair, so they are P×P tables, and the modulated feature
  row depends only on (receiver class, sender j): one row per such *virtual sender*
  (≈ 1.1 N rows instead of E ≈ 43 N). The convolution then reads the virtual senders
  through :meth:`ConvGeometry.with_sources`.
* ``"edges"`` (general path, continuous densities): one row per edge, γ, β from the MLPs
  per edge.

Both give the same result up to summation order (tested).
"""
from __future__ import annotations

import numba as nb
import numpy as np
import torch
from torch import nn

from ..particles import RHO_REF
from .cconv import ConvGeometry, _spread


def mlp(sizes: list[int]) -> nn.Sequential:
    """Linear layers with ReLU between them (none after the last)."""
    layers: list[nn.Module] = []
    for a, b in zip(sizes[:-1], sizes[1:]):
        layers += [nn.Linear(a, b), nn.ReLU()]
    return nn.Sequential(*layers[:-1])


class DensityEmbedding(nn.Module):
    """e = φ(log(1 + ρ/ρ_ref)) (eq. 4)."""

    def __init__(self, dim: int = 8, hidden: int = 16, rho_ref: float = RHO_REF):
        super().__init__()
        self.rho_ref = float(rho_ref)
        self.phi = mlp([1, hidden, dim])

    def forward(self, rho: torch.Tensor) -> torch.Tensor:
        return self.phi(torch.log1p(rho / self.rho_ref).unsqueeze(-1))

    def reference(self, like: torch.Tensor) -> torch.Tensor:
        """e_ref = φ(log 2), the embedding of ρ_ref (same code path as :meth:`forward`)."""
        return self(torch.full((1,), self.rho_ref, dtype=like.dtype, device=like.device))


class PairModulation(nn.Module):
    """γ_ij, β_ij ∈ R^C from (e_i, e_j) (eq. 5), identity at the reference (eq. 7).

    With ``symmetric`` the logits are averaged over (i, j) and (j, i), so γ_ij = γ_ji and
    β_ij = β_ji (needed by the antisymmetric, momentum-conserving layer).
    """

    def __init__(self, embed_dim: int, channels: int, hidden: int = 32, symmetric: bool = False):
        super().__init__()
        self.gamma_mlp = mlp([2 * embed_dim, hidden, channels])
        self.beta_mlp = mlp([2 * embed_dim, hidden, channels])
        self.symmetric = symmetric

    def _logits(self, ei, ej):
        z = torch.cat([ei, ej], dim=-1)
        g, b = self.gamma_mlp(z), self.beta_mlp(z)
        if self.symmetric:
            zt = torch.cat([ej, ei], dim=-1)
            g = 0.5 * (g + self.gamma_mlp(zt))
            b = 0.5 * (b + self.beta_mlp(zt))
        return g, b

    def forward(self, ei: torch.Tensor, ej: torch.Tensor, eref: torch.Tensor):
        """γ, β for broadcastable embeddings ``ei``, ``ej`` [..., d_e]; ``eref`` [1, d_e]."""
        ei, ej = torch.broadcast_tensors(ei, ej)
        g, b = self._logits(ei, ej)
        g0, b0 = self._logits(eref, eref)
        return 2.0 * torch.sigmoid(g - g0), b - b0


def _take(t: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """Rows ``t[idx]`` by ``index_select``: the same values as advanced indexing, but its
    backward is a fast ``index_add`` (advanced indexing's ``index_put_(accumulate=True)``
    was the largest single cost of a ``dcdc`` training step on the CPU)."""
    return t.index_select(0, idx)


@nb.njit(cache=True, parallel=True)
def _modulated_rows(gam, bet, pk, pj, f, out):
    """out[u] = gam[pk[u]] · f[pj[u]] + bet[pk[u]]: the class path's Γ rows in one pass (no
    fastmath: the same two roundings as the torch expression, so the same numbers)."""
    C = f.shape[1]
    for u in nb.prange(out.shape[0]):
        g = gam[pk[u]]
        b = bet[pk[u]]
        fj = f[pj[u]]
        o = out[u]
        for c in range(C):
            o[c] = g[c] * fj[c] + b[c]


@nb.njit(cache=True)
def _virtual_senders(row_splits, index, cls, n_send, n_cls):
    """One id per distinct (receiver class, sender) pair, in order of first appearance."""
    idmap = np.full(n_cls * n_send, -1, dtype=np.int32)
    n_edges = index.shape[0]
    src = np.empty(n_edges, dtype=np.int32)
    pair_cls = np.empty(n_edges, dtype=np.int32)
    pair_j = np.empty(n_edges, dtype=np.int32)
    u = 0
    for i in range(row_splits.shape[0] - 1):
        a = cls[i]
        for e in range(row_splits[i], row_splits[i + 1]):
            key = a * n_send + index[e]
            if idmap[key] < 0:
                idmap[key] = u
                pair_cls[u] = a
                pair_j[u] = index[e]
                u += 1
            src[e] = idmap[key]
    return src, pair_cls[:u].copy(), pair_j[:u].copy()


class DensityPlan:
    """Per-step bookkeeping of the density modulation over one fluid→fluid geometry.

    Args:
        geom: fluid→fluid :class:`ConvGeometry` (senders = receivers = fluid particles).
        density: [N] densities (numpy or torch).
        mode: "auto" (classes when ≤ ``max_classes`` distinct values), "classes", "edges".
    """

    def __init__(self, geom: ConvGeometry, density, mode: str = "auto", max_classes: int = 16):
        rho = density.detach().cpu().numpy() if isinstance(density, torch.Tensor) else np.asarray(density)
        rho = np.ascontiguousarray(rho, dtype=np.float64).reshape(-1)
        self.geom = geom
        self.rho = rho
        uniq, cls = np.unique(rho, return_inverse=True)
        if mode == "auto":
            mode = "classes" if len(uniq) <= max_classes else "edges"
        if mode not in ("classes", "edges"):
            raise ValueError(f"unknown density plan mode {mode!r}")
        self.mode = mode
        self._edge_geom = None
        self._lazy: dict = {}  # per-edge index arrays, built on first use (see _edge_arrays)
        if mode == "classes":
            self.uniq = uniq
            self.cls = cls.astype(np.int32).reshape(-1)
            src, pc, pj = _virtual_senders(geom.row_splits, geom.sender, self.cls, geom.n_send,
                                           len(uniq))
            self.pair_geom = geom.with_sources(src, len(pj))
            self._pc = torch.from_numpy(pc.astype(np.int64))
            self._pj = torch.from_numpy(pj.astype(np.int64))
            self._pjc = torch.from_numpy(self.cls[pj].astype(np.int64))
            self._pk = self._pc * len(uniq) + self._pjc  # (receiver class, sender class) pair
        else:
            self.pair_geom = self.edge_geom

    def _edge_arrays(self) -> dict:
        """Receiver/sender particle (and class) of every edge, int64. Only the per-edge paths
        (continuous densities, the antisymmetric layer) read them, so a ``dcdc`` step on the
        class path never builds these E-long arrays."""
        lz = self._lazy
        if not lz:
            lz["recv"] = self.geom.receivers().astype(np.int64)
            lz["send"] = self.geom.sender.astype(np.int64)
            lz["recv_t"] = torch.from_numpy(lz["recv"])
            lz["send_t"] = torch.from_numpy(lz["send"])
            if self.mode == "classes":
                lz["ec"] = torch.from_numpy(self.cls[lz["recv"]].astype(np.int64))
                lz["es"] = torch.from_numpy(self.cls[lz["send"]].astype(np.int64))
        return lz

    @property
    def recv(self) -> np.ndarray:
        return self._edge_arrays()["recv"]

    @property
    def send(self) -> np.ndarray:
        return self._edge_arrays()["send"]

    def edge_index(self, device) -> tuple[torch.Tensor, torch.Tensor]:
        """(receiver, sender) particle index of every edge, int64 tensors on ``device``."""
        lz = self._edge_arrays()
        return lz["recv_t"].to(device), lz["send_t"].to(device)

    def plain_symmetric_edges(self, f: torch.Tensor):
        """Per-edge rows f_i + f_j (the unconditioned antisymmetric layer)."""
        i, j = self.edge_index(f.device)
        return _take(f, i) + _take(f, j), self.edge_geom

    @property
    def edge_geom(self) -> ConvGeometry:
        """The geometry with one virtual sender per edge (injective)."""
        if self._edge_geom is None:
            self._edge_geom = self.geom.with_sources(np.arange(self.geom.n_edges, dtype=np.int32),
                                                     self.geom.n_edges, injective=True)
        return self._edge_geom

    def _embed(self, embedding: DensityEmbedding, like: torch.Tensor, values: np.ndarray):
        return embedding(torch.as_tensor(values, dtype=like.dtype, device=like.device))

    def modulated(self, f: torch.Tensor, mod: PairModulation, embedding: DensityEmbedding):
        """(rows, geometry): Γ rows (one per virtual sender) and the geometry that reads them."""
        eref = embedding.reference(f)
        dev = f.device
        if self.mode == "classes":
            e = self._embed(embedding, f, self.uniq)  # [P, d_e]
            gam, bet = mod(e[:, None, :], e[None, :, :], eref)  # [P, P, C]
            C = gam.shape[-1]
            if dev.type == "cpu" and not (f.requires_grad or gam.requires_grad or bet.requires_grad):
                # inference: one numba pass instead of three gathers and two [U, C] temporaries
                rows = torch.empty(len(self._pk), C, dtype=f.dtype)
                _modulated_rows(gam.reshape(-1, C).contiguous().numpy(),
                                bet.reshape(-1, C).contiguous().numpy(), self._pk.numpy(),
                                self._pj.numpy(), f.contiguous().numpy(), rows.numpy())
                return rows, self.pair_geom
            pk, j = self._pk.to(dev), self._pj.to(dev)
            rows = _take(gam.reshape(-1, C), pk) * _take(f, j) + _take(bet.reshape(-1, C), pk)
            return rows, self.pair_geom
        e = self._embed(embedding, f, self.rho)  # [N, d_e]
        i, j = self.edge_index(dev)
        gam, bet = mod(_take(e, i), _take(e, j), eref)
        return gam * _take(f, j) + bet, self.edge_geom

    def symmetric_edges(self, f: torch.Tensor, mod: PairModulation, embedding: DensityEmbedding):
        """Per-edge rows Γˢ_ij = γˢ_ij ⊙ (f_i + f_j) + βˢ_ij, symmetric in (i, j)."""
        eref = embedding.reference(f)
        dev = f.device
        i, j = self.edge_index(dev)
        pair = _take(f, i) + _take(f, j)
        if self.mode == "classes":
            e = self._embed(embedding, f, self.uniq)
            gam, bet = mod(e[:, None, :], e[None, :, :], eref)
            lz = self._edge_arrays()
            ck = lz["ec"].to(dev) * len(self.uniq) + lz["es"].to(dev)
            C = gam.shape[-1]
            return (_take(gam.reshape(-1, C), ck) * pair + _take(bet.reshape(-1, C), ck),
                    self.edge_geom)
        e = self._embed(embedding, f, self.rho)
        gam, bet = mod(_take(e, i), _take(e, j), eref)
        return gam * pair + bet, self.edge_geom

    def class_window_sums(self, like: torch.Tensor) -> torch.Tensor:
        """S[i, c, b] = Σ_{j ∈ N(i), class(j) = b} Σ_k [cell_k = c]·weight_k   [R, cells, P]."""
        key = (like.dtype, str(like.device))
        cache = self.__dict__.setdefault("_sums", {})
        if key not in cache:
            g = self.geom
            P = len(self.uniq)
            npdt = torch.empty(0, dtype=like.dtype).numpy().dtype
            onehot = np.zeros((g.n_send, P), dtype=npdt)
            onehot[np.arange(g.n_send), self.cls] = 1.0
            S = np.empty((g.n_recv, g.n_cells * P), dtype=npdt)
            if g.n_recv:
                _spread(g.row_splits, g.sender, g.cells, g.weights_as(like.dtype), onehot, 0,
                        g.n_recv, S)
            cache[key] = torch.from_numpy(S).reshape(g.n_recv, g.n_cells, P).to(like.device)
        return cache[key]

    def symmetric_split(self, f: torch.Tensor, mod: PairModulation, embedding: DensityEmbedding):
        """Γˢ_ij split for the class path: γˢ_ij ⊙ f_j (per virtual sender) + h_i,class(j).

        Returns (rows [U, C], pair geometry, h [R, P, C], S [R, cells, P]) with
        h[i, b] = γˢ(a_i, b) ⊙ f_i + βˢ(a_i, b), so that
        Σ_j g(u_ij)ᵀ Γˢ_ij = conv(rows) + Σ_{c,b} S[i,c,b]·(h[i,b] @ W_c).
        """
        if self.mode != "classes":
            raise ValueError("symmetric_split needs the classes plan")
        e = self._embed(embedding, f, self.uniq)
        gam, bet = mod(e[:, None, :], e[None, :, :], embedding.reference(f))  # [P, P, C]
        dev = f.device
        pk, j = self._pk.to(dev), self._pj.to(dev)
        rows = _take(gam.reshape(-1, gam.shape[-1]), pk) * _take(f, j)
        ci = torch.from_numpy(self.cls.astype(np.int64)).to(dev)
        h = _take(gam, ci) * f[:, None, :] + _take(bet, ci)  # [R, P, C]
        return rows, self.pair_geom, h, self.class_window_sums(f)
