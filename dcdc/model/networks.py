"""The position-correction networks (DESIGN §4), selected by name.

All three share the DeepLagrangianFluids layout (Ummenhofer et al. 2020):

* inputs per fluid particle: [1, v] (d + 1 channels; the ``cconv`` baseline adds
  log(1 + ρ/ρ_ref) as a passive input channel), wall particles carry their normals;
* layer 0: fluid→fluid conv ‖ wall→fluid conv ‖ dense, each 32 channels, concatenated;
* layers 1..: conv + dense on ReLU'd features (64, 64), residual where the width is kept;
* last layer: conv + dense to d channels; Δx = output / 128.

Names (:data:`NETWORKS`):

* ``dcdc`` — every fluid→fluid conv is density-conditioned (eqs. 3–5);
* ``cconv`` — plain CConv with density as an input channel (the paper's "passive" baseline);
* ``dcdc-antisym`` — ``dcdc`` whose last layer is the antisymmetric conv of Prantl et al.
  2022 with a symmetric density condition plus a wall conv (walls are external), and no
  dense term: Δx_i = (ρ_ref/ρ_i)·Σ_j t_ij / 128 + wall term, so Σ_i ρ_i Δx_i = 0 without
  walls (linear momentum is conserved; particle masses are ∝ ρ at equal volume).

``build_network(name, dim, **cfg)`` builds one; :meth:`CorrectionNet.config` returns the
dict that rebuilds it (used by checkpoints).
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields

import numpy as np
import torch
from torch import nn

from ..errors import DcdcError
from ..neighbors import Neighbors, radius_search
from ..particles import DEFAULT_RADIUS, RHO_REF
from .cconv import ConvGeometry, build_geometry
from .layers import AntisymCConvLayer, CConvLayer, DensityCConvLayer
from .modulation import DensityEmbedding, DensityPlan


@dataclass
class NetConfig:
    """Hyper-parameters of a correction network (all stored in checkpoints)."""

    radius: float = 4.5 * DEFAULT_RADIUS  # CConv radius R (DESIGN §2)
    kernel_size: int = 4
    channels: tuple = (32, 64, 64)  # hidden widths; the output layer has d channels
    embed_dim: int = 8  # d_e of eq. 4
    embed_hidden: int = 16
    mod_hidden: int = 32
    normalize: bool = False  # divide conv weights by the window sum
    rho_ref: float = RHO_REF
    out_scale: float = 1.0 / 128.0
    density_mode: str = "auto"  # "auto" | "classes" (fast path) | "edges" (per-edge)
    max_classes: int = 16


@dataclass
class StepContext:
    """Geometry shared by all layers of one forward pass."""

    fluid: ConvGeometry
    wall: ConvGeometry
    plan: DensityPlan | None


class CorrectionNet(nn.Module):
    """Δx = net(x*, v*, ρ, walls): the neural correction ε of eqs. 1–3."""

    name = "base"
    conditioned = False
    density_input = False
    antisymmetric = False

    def __init__(self, dim: int = 3, **cfg):
        super().__init__()
        if dim not in (2, 3):
            raise DcdcError(f"network dim must be 2 or 3 (got {dim})")
        known = {f.name for f in fields(NetConfig)}
        unknown = set(cfg) - known
        if unknown:
            raise DcdcError(f"unknown network option(s) {sorted(unknown)} for {self.name!r}")
        if "channels" in cfg:
            cfg["channels"] = tuple(int(c) for c in cfg["channels"])
        self.cfg = NetConfig(**cfg)
        if self.antisymmetric and self.cfg.normalize:
            raise DcdcError("dcdc-antisym needs normalize=false (normalisation breaks antisymmetry)")
        self.dim = dim
        c = self.cfg
        K, ch = c.kernel_size, list(c.channels)
        cin = 1 + dim + (1 if self.density_input else 0)
        self.embedding = DensityEmbedding(c.embed_dim, c.embed_hidden, c.rho_ref) if self.conditioned else None

        def fluid_conv(a, b):
            if self.conditioned:
                return DensityCConvLayer(a, b, dim, K, c.embed_dim, c.mod_hidden)
            return CConvLayer(a, b, dim, K)

        self.conv0_fluid = fluid_conv(cin, ch[0])
        self.conv0_wall = CConvLayer(dim, ch[0], dim, K)
        self.dense0 = nn.Linear(cin, ch[0])
        widths = [3 * ch[0]] + ch[1:] + [dim]
        self.convs = nn.ModuleList()
        self.denses = nn.ModuleList()
        for i, (a, b) in enumerate(zip(widths[:-1], widths[1:])):
            last = i == len(widths) - 2
            if last and self.antisymmetric:
                self.convs.append(AntisymCConvLayer(a, b, dim, K, c.embed_dim, c.mod_hidden,
                                                    conditioned=self.conditioned))
                self.denses.append(nn.Identity())
            else:
                self.convs.append(fluid_conv(a, b))
                self.denses.append(nn.Linear(a, b))
        self.wall_out = CConvLayer(dim, dim, dim, K) if self.antisymmetric else None
        self.profile = False
        self.timings: dict[str, float] = {}

    # ------------------------------------------------------------------ config
    def config(self) -> dict:
        d = asdict(self.cfg)
        d["channels"] = list(d["channels"])
        return {"name": self.name, "dim": self.dim, **d}

    def set_backend(self, backend: str = "auto", gemm_dtype: torch.dtype | None = None):
        """CConv backend ("auto" | "numba" | "torch") and optional bf16 GEMMs (inference)."""
        for m in self.modules():
            if isinstance(m, CConvLayer):
                m.backend, m.gemm_dtype = backend, gemm_dtype
        return self

    @contextmanager
    def _timed(self, key: str):
        if not self.profile:
            yield
            return
        t0 = time.perf_counter()
        yield
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - t0

    # ------------------------------------------------------------------ forward
    def prepare(self, x, density, wall_x=None) -> StepContext:
        """Neighbour search + geometry + density plan (no gradients; positions are data)."""
        c = self.cfg
        xn = x.detach().cpu().double().numpy() if isinstance(x, torch.Tensor) else x
        with self._timed("search"):
            nb_f = radius_search(xn, c.radius, exclude_self=True)
            nb_w = None
            if wall_x is not None and len(wall_x):
                wn = wall_x.detach().cpu().double().numpy() if isinstance(wall_x, torch.Tensor) else wall_x
                nb_w = radius_search(xn, c.radius, wn)
        with self._timed("geometry"):
            fluid = build_geometry(xn, None, c.radius, c.kernel_size, True, c.normalize, neighbors=nb_f)
            if nb_w is None:
                wall = build_geometry(xn, np.zeros((0, self.dim)), c.radius, c.kernel_size,
                                      False, c.normalize,
                                      neighbors=_empty_neighbors(len(xn)))
            else:
                wall = build_geometry(xn, wn, c.radius, c.kernel_size, False, c.normalize,
                                      neighbors=nb_w)
            plan = None
            if self.conditioned or self.antisymmetric:
                plan = DensityPlan(fluid, density, c.density_mode, c.max_classes)
        return StepContext(fluid, wall, plan)

    def forward(self, x, v, density, wall_x=None, wall_n=None, ctx: StepContext | None = None):
        """Position correction Δx [N, d] for the inertially advanced state (x*, v*).

        Args:
            x: [N, d] positions x* (used only through the neighbour geometry).
            v: [N, d] velocities v* (network input; gradients flow through it).
            density: [N] rest density of each particle's phase [kg/m³].
            wall_x, wall_n: [M, d] wall particle positions and normals (optional).
            ctx: a precomputed :meth:`prepare` result for these positions.
        """
        if ctx is None:
            ctx = self.prepare(x, density, wall_x)
        p = next(self.parameters())
        dtype, dev = p.dtype, p.device
        v = torch.as_tensor(v).to(dtype=dtype, device=dev)
        rho = torch.as_tensor(density).to(dtype=dtype, device=dev).reshape(-1)
        n = v.shape[0]
        with self._timed("convolutions"):
            feats = [torch.ones(n, 1, dtype=dtype, device=dev), v]
            if self.density_input:
                feats.append(torch.log1p(rho / self.cfg.rho_ref).unsqueeze(1))
            f = torch.cat(feats, dim=1)
            if wall_n is None or ctx.wall.n_send == 0:
                wn = torch.zeros(ctx.wall.n_send, self.dim, dtype=dtype, device=dev)
            else:
                wn = torch.as_tensor(wall_n).to(dtype=dtype, device=dev)
            h = torch.cat([self._fluid(self.conv0_fluid, f, ctx),
                           self.conv0_wall(wn, ctx.wall), self.dense0(f)], dim=1)
            for i, (conv, dense) in enumerate(zip(self.convs, self.denses)):
                a = torch.relu(h)
                last = i == len(self.convs) - 1
                if last and self.antisymmetric:
                    t = conv(a, ctx.fluid, ctx.plan, self.embedding)
                    out = t * (self.cfg.rho_ref / rho).unsqueeze(1) + self.wall_out(wn, ctx.wall)
                else:
                    out = self._fluid(conv, a, ctx) + dense(a)
                    if out.shape == h.shape:
                        out = out + h
                h = out
        return h * self.cfg.out_scale

    def _fluid(self, conv, f, ctx: StepContext):
        if isinstance(conv, DensityCConvLayer):
            return conv(f, ctx.fluid, ctx.plan, self.embedding)
        return conv(f, ctx.fluid)


def _empty_neighbors(n: int) -> Neighbors:
    return Neighbors(np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int32))


class DCDCNet(CorrectionNet):
    """Ours: density-conditioned fluid convolutions (paper §3)."""

    name = "dcdc"
    conditioned = True


class CConvNet(CorrectionNet):
    """Baseline: plain CConv with log(1 + ρ/ρ_ref) as a passive input channel."""

    name = "cconv"
    density_input = True


class DCDCAntisymNet(CorrectionNet):
    """dcdc with a momentum-conserving antisymmetric last layer (Prantl et al. 2022)."""

    name = "dcdc-antisym"
    conditioned = True
    antisymmetric = True


NETWORKS: dict[str, type[CorrectionNet]] = {c.name: c for c in (DCDCNet, CConvNet, DCDCAntisymNet)}


def build_network(name: str, dim: int = 3, **cfg) -> CorrectionNet:
    """A network by registry name (``dcdc``, ``cconv``, ``dcdc-antisym``) and options."""
    if name not in NETWORKS:
        raise DcdcError(f"unknown network {name!r}; choose one of {', '.join(NETWORKS)}")
    return NETWORKS[name](dim, **cfg)
