"""The position-correction networks (docs/model.md, "Networks"), selected by name.

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
from ..neighbors import CellGrid, Neighbors, nearest_values, radius_search
from ..configs import check, check_types
from ..particles import DEFAULT_RADIUS, FRAME_DT, RHO_REF
from .cconv import ConvGeometry, build_geometry
from .layers import AntisymCConvLayer, CConvLayer, DensityCConvLayer
from .modulation import DensityEmbedding, DensityPlan
from .walls import FilledWalls


@dataclass
class NetConfig:
    """Hyper-parameters of a correction network (all stored in checkpoints).

    The network knows the data it is made for: the particle radius r and the
    frame Δt of one neural step. Its convolution radius is derived from r as in
    DeepLagrangianFluids (Ummenhofer et al. 2020: filter extent 1.5 · 6 r, i.e. R = 4.5 r):
    R = ``radius_scale`` · ``particle_radius`` (:attr:`radius`).
    """

    particle_radius: float = DEFAULT_RADIUS  # r of the training data [m]
    radius_scale: float = 4.5  # CConv radius R in particle radii
    frame_dt: float = FRAME_DT  # Δt of one neural step = the data's frame interval [s]
    kernel_size: int = 4
    channels: tuple[int, ...] = (32, 64, 64)  # hidden widths; the output layer has d channels
    embed_dim: int = 8  # d_e of eq. 4
    embed_hidden: int = 16
    mod_hidden: int = 32
    normalize: bool = False  # divide conv weights by the window sum
    rho_ref: float = RHO_REF
    out_scale: float = 1.0 / 128.0
    density_mode: str = "auto"  # "auto" | "classes" (fast path) | "edges" (per-edge)
    max_classes: int = 16
    # log(1 + ρ/ρ_ref) as an input channel; None = the architecture's own choice (``cconv``:
    # yes, the others: no). ``cconv`` without it is DeepLagrangianFluids' network.
    density_input: bool | None = None
    # the wall conv sees the far face of a thin wall too (True: every wall particle within R;
    # False: not the wall particles a particle lies more than r behind that face away from its
    # nearest wall particle, facing_walls)
    wall_far_faces: bool = False
    # wall particles added in the diagonal gaps of lattice-sampled slanted walls
    # (dcdc.model.walls.fill_wall_gaps)
    wall_fill_gaps: bool = False

    def __post_init__(self):
        self.validate()

    @property
    def radius(self) -> float:
        """The CConv radius R = radius_scale · particle_radius [m]."""
        return self.radius_scale * self.particle_radius

    def validate(self) -> "NetConfig":
        """Types and ranges; one-line DcdcError naming the option otherwise."""
        check_types(self, "network option ")
        for name in ("particle_radius", "radius_scale", "frame_dt", "rho_ref", "out_scale"):
            v = getattr(self, name)
            check(v > 0, f"network option {name}", "> 0", v)
        check(self.kernel_size >= 2, "network option kernel_size", "an integer >= 2",
              self.kernel_size)
        check(len(self.channels) >= 1 and all(c >= 1 for c in self.channels),
              "network option channels", "a non-empty list of positive integers",
              list(self.channels))
        for name in ("embed_dim", "embed_hidden", "mod_hidden", "max_classes"):
            v = getattr(self, name)
            check(v >= 1, f"network option {name}", "an integer >= 1", v)
        check(self.density_mode in DENSITY_MODES, "network option density_mode",
              f"one of {', '.join(DENSITY_MODES)}", self.density_mode)
        return self


DENSITY_MODES = ("auto", "classes", "edges")


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
        self.cfg = NetConfig(**cfg)
        if self.cfg.density_input is None:
            self.cfg.density_input = type(self).density_input
        self.density_input = self.cfg.density_input
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
        self._wall_grids = WallGrids()  # the wall cell lists, kept while the walls stay put
        self._filled_walls = FilledWalls()  # NetConfig.wall_fill_gaps, kept likewise
        self._search_caps = (128, 128)  # one-pass search bounds (fluid, wall): _next_capacity
        self.last_context: StepContext | None = None

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
    def prepare(self, x, density, wall_x=None, scenes: "Scenes | None" = None,
                wall_n=None) -> StepContext:
        """Neighbour search + geometry + density plan (no gradients; positions are data).

        ``scenes``: several scenes concatenated into one batch (:class:`Scenes`); each is
        searched on its own, so particles of different scenes never interact. With the wall
        normals ``wall_n``, the wall particles a particle lies behind are left out of its
        wall neighbours (:func:`facing_walls`, ``NetConfig.wall_far_faces``)."""
        wall_x, wall_n, scenes = self.network_walls(wall_x, wall_n, scenes)
        return self._prepare(x, density, wall_x, scenes, wall_n)

    def _prepare(self, x, density, wall_x, scenes, wall_n) -> StepContext:
        """:meth:`prepare` for the walls the network sees (:meth:`network_walls` done)."""
        c = self.cfg
        xn = _numpy(x)
        wn = _numpy(wall_x) if wall_x is not None else np.zeros((0, self.dim))
        dtype = next(self.parameters()).dtype
        if dtype not in (torch.float32, torch.float64):
            dtype = torch.float64
        caps = self._search_caps
        with self._timed("search"):
            nb_f = _search(xn, c.radius, None, scenes, exclude_self=True, capacity=caps[0])
            nb_w = (_search(xn, c.radius, wn, scenes, grids=self._wall_grids.get(wn, c.radius, scenes),
                            capacity=caps[1]) if len(wn) else _empty_neighbors(len(xn)))
            self._search_caps = (_next_capacity(nb_f), _next_capacity(nb_w))
            if wall_n is not None and len(wn) and not c.wall_far_faces:
                nb_w = facing_walls(nb_w, xn, wn, _numpy(wall_n), c.particle_radius)
        with self._timed("geometry"):
            fluid = build_geometry(xn, None, c.radius, c.kernel_size, True, c.normalize,
                                   neighbors=nb_f, dtype=dtype)
            wall = build_geometry(xn, wn if len(wn) else np.zeros((0, self.dim)), c.radius,
                                  c.kernel_size, False, c.normalize, neighbors=nb_w, dtype=dtype)
            plan = None
            if self.conditioned or self.antisymmetric:
                plan = DensityPlan(fluid, density, c.density_mode, c.max_classes)
        return StepContext(fluid, wall, plan)

    def forward(self, x, v, density, wall_x=None, wall_n=None, ctx: StepContext | None = None,
                scenes: "Scenes | None" = None):
        """Position correction Δx [N, d] for the inertially advanced state (x*, v*).

        Args:
            x: [N, d] positions x* (used only through the neighbour geometry).
            v: [N, d] velocities v* (network input; gradients flow through it).
            density: [N] rest density of each particle's phase [kg/m³].
            wall_x, wall_n: [M, d] wall particle positions and normals (optional).
            ctx: a precomputed :meth:`prepare` result for these positions.
            scenes: where each scene of a concatenated batch starts (:class:`Scenes`).
        """
        wall_x, wall_n, scenes = self.network_walls(wall_x, wall_n, scenes)
        if ctx is None:
            ctx = self._prepare(x, density, wall_x, scenes, wall_n)
        self.last_context = ctx  # e.g. the loss weights particles by their neighbour count
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

    def network_walls(self, wall_x, wall_n, scenes: "Scenes | None" = None):
        """The wall particles the network sees: as given, or with the gaps of slanted
        lattice walls filled (``NetConfig.wall_fill_gaps``, :func:`fill_wall_gaps`); the
        scenes' wall offsets follow the added rows."""
        if not self.cfg.wall_fill_gaps or wall_x is None or wall_n is None or len(wall_x) == 0:
            return wall_x, wall_n, scenes
        wx, wn, offs = self._filled_walls.get(_numpy(wall_x), _numpy(wall_n),
                                              2 * self.cfg.particle_radius,
                                              None if scenes is None else scenes.wall)
        if scenes is not None:
            scenes = Scenes(scenes.fluid, offs)
        return wx, wn, scenes

    def _fluid(self, conv, f, ctx: StepContext):
        if isinstance(conv, DensityCConvLayer):
            return conv(f, ctx.fluid, ctx.plan, self.embedding)
        return conv(f, ctx.fluid)


def _next_capacity(nb: Neighbors) -> int | None:
    """Neighbour bound for the next step's one-pass search: 1.25 × this step's largest count
    + 8 (states change little per step; a query above it only costs the two-pass fill).
    ``None`` (the two-pass search) when a clump makes the bound far above the mean count:
    the one-pass scratch is [queries, bound] and must stay small."""
    n = len(nb.row_splits) - 1
    if n == 0:
        return 32
    counts = nb.counts
    cap = max(32, int(1.25 * int(counts.max())) + 8)
    return cap if cap <= 4 * nb.n_edges / n + 32 else None


def facing_walls(nb: Neighbors, x: np.ndarray, wall_x: np.ndarray, wall_n: np.ndarray,
                 behind: float) -> Neighbors:
    """The wall neighbours ``nb`` of the particles ``x`` without the far faces of thin walls:
    a wall particle b is left out when the particle lies behind it by more than ``behind``
    [m], (x_i − x_b)·n_b < −behind (normals point into the fluid), and b faces away from the
    particle's nearest wall particle (normals more than 60° apart).

    A thin wall (a glass, an hourglass's shell) is sampled on both faces with opposite
    normals; without this a particle beside the inner face also sees the outer one, whose
    normals point away from it: on the suite's glasses and hourglasses 26-28 % of the SPH
    run's wall pairs, none in boxes, on terrain or in mesh vessels. Layers that face the
    same way as the nearest (a solid wall's deeper layers, a corner's) stay, so a particle
    that has gone into a wall still sees what pushes it out."""
    if nb.n_edges == 0:
        return nb
    recv = nb.receivers()
    off = x[recv] - wall_x[nb.index]
    n = wall_n[nb.index]
    side = np.einsum("ij,ij->i", off, n)
    behind_b = side < -behind
    if not behind_b.any():
        return nb
    nearest_n = nearest_values(recv, np.einsum("ij,ij->i", off, off), n, len(x))
    keep = ~behind_b | (np.einsum("ij,ij->i", n, nearest_n[recv]) > 0.5)
    if keep.all():
        return nb
    counts = np.bincount(recv[keep], minlength=len(nb.row_splits) - 1)
    return Neighbors(np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
                     np.ascontiguousarray(nb.index[keep]))


def _empty_neighbors(n: int) -> Neighbors:
    return Neighbors(np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int32))


def _numpy(a) -> np.ndarray:
    if isinstance(a, torch.Tensor):
        return a.detach().cpu().double().numpy()
    return np.asarray(a, dtype=np.float64)


@dataclass
class Scenes:
    """Several scenes concatenated into one batch: scene b owns fluid rows
    ``fluid[b]:fluid[b+1]`` and wall rows ``wall[b]:wall[b+1]`` (int offsets, length B + 1)."""

    fluid: np.ndarray
    wall: np.ndarray

    def __post_init__(self):
        self.fluid = np.asarray(self.fluid, dtype=np.int64)
        self.wall = np.asarray(self.wall, dtype=np.int64)
        if (len(self.fluid) != len(self.wall) or len(self.fluid) < 2 or self.fluid[0] != 0
                or self.wall[0] != 0 or (np.diff(self.fluid) < 0).any()
                or (np.diff(self.wall) < 0).any()):
            raise DcdcError("scene offsets must be two non-decreasing arrays of equal length "
                            "starting at 0")

    @classmethod
    def from_counts(cls, fluid_counts, wall_counts) -> "Scenes":
        return cls(np.concatenate([[0], np.cumsum(fluid_counts)]),
                   np.concatenate([[0], np.cumsum(wall_counts)]))

    @property
    def n_scenes(self) -> int:
        return len(self.fluid) - 1


class WallGrids:
    """The cell lists of the wall particles (one per scene), rebuilt only when the walls change.

    Walls are static in a rollout and in every showcase, so :meth:`CorrectionNet.prepare`
    bins them once and only bins the fluid queries each step. The key is the wall array's
    content (an exact comparison, microseconds for thousands of walls), the radius and the
    scene offsets; the grids are the ones ``radius_search`` would build, so the neighbour
    lists are identical."""

    def __init__(self):
        self._key = None
        self._points: np.ndarray | None = None
        self._grids: list | None = None
        self.builds = 0  # how often the grids were (re)built (tests)

    def get(self, points: np.ndarray, radius: float, scenes: Scenes | None) -> list:
        offs = None if scenes is None else tuple(scenes.wall.tolist())
        key = (float(radius), offs, points.shape, points.dtype.str)
        if (self._key != key or self._points is None
                or not np.array_equal(self._points, points)):
            spans = [(0, len(points))] if offs is None else list(zip(offs[:-1], offs[1:]))
            self._grids = [CellGrid(points[a:b], radius) if b > a else None for a, b in spans]
            self._points, self._key = np.array(points, copy=True), key
            self.builds += 1
        return self._grids


def _search(x: np.ndarray, radius: float, points: np.ndarray | None, scenes: Scenes | None,
            exclude_self: bool = False, grids: list | None = None,
            capacity: int | None = None) -> Neighbors:
    """Radius search of ``x`` in ``points`` (None: in ``x`` itself), scene by scene.

    One cell-list search per scene (scenes may overlap in space, and far-apart scenes would
    blow up a shared grid); the per-scene CSR lists are joined with index offsets.
    ``grids``: prebuilt cell lists of ``points``, one per scene (:class:`WallGrids`);
    ``capacity``: the one-pass search bound (:meth:`CellGrid.search`, same result)."""
    if scenes is None:
        if grids is not None:
            return grids[0].search(x, capacity=capacity)
        return radius_search(x, radius, points, exclude_self=exclude_self, capacity=capacity)
    same = points is None
    offs_p = scenes.fluid if same else scenes.wall
    if scenes.fluid[-1] != len(x) or offs_p[-1] != (len(x) if same else len(points)):
        raise DcdcError(f"scene offsets cover {scenes.fluid[-1]} fluid / {scenes.wall[-1]} wall "
                        f"rows, the batch has {len(x)} / {len(x) if same else len(points)}")
    splits, index = [np.zeros(1, dtype=np.int64)], []
    edges = 0
    for b in range(scenes.n_scenes):
        q = x[scenes.fluid[b]:scenes.fluid[b + 1]]
        if same:
            nb = radius_search(q, radius, exclude_self=exclude_self, capacity=capacity)
        elif grids is not None:
            nb = (grids[b].search(q, capacity=capacity) if grids[b] is not None
                  else _empty_neighbors(len(q)))
        else:
            p = points[offs_p[b]:offs_p[b + 1]]
            nb = radius_search(q, radius, p, capacity=capacity) if len(p) else _empty_neighbors(len(q))
        splits.append(nb.row_splits[1:] + edges)
        index.append(nb.index + np.int32(offs_p[b]))
        edges += nb.n_edges
    return Neighbors(np.concatenate(splits),
                     np.concatenate(index).astype(np.int32) if index else np.zeros(0, np.int32))


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
