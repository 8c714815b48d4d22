"""The training loss: CConv's neighbour-weighted position error over unrolled steps.

For a window with frames x⁰ … x^U (Ummenhofer et al. 2020, §4 "Training"; their
published code trains with U = 2 and step weights ½, ½)::

    x̂⁰ = x⁰, v̂⁰ = v⁰;   (x̂ᵏ, v̂ᵏ) = step(x̂ᵏ⁻¹, v̂ᵏ⁻¹)                (Algorithm 1)
    Lᵏ = mean_i  exp(−nᵢᵏ / n₀) · (‖x̂ᵢᵏ − xᵢᵏ‖² + ε)^(γ/2)            γ = 0.5, n₀ = 40
    L  = Σₖ wₖ Lᵏ,  Σₖ wₖ = 1

* nᵢᵏ is particle i's number of fluid neighbours within the CConv radius at step k (the
  network's own search at x*, self excluded). Interior particles are pinned by their
  neighbours; the weight shifts the loss to the free surface and splashes where errors
  grow. In 3-D the interior holds ≈ 48 (continuum estimate, 56 on a cubic lattice at
  spacing 2r): weight ≈ 0.3, a lone droplet 1. In 2-D it holds only ≈ 15 (90th percentile
  in data/sample, median 13), so examples/train_2d.toml sets n₀ = 13.3 for the same
  interior weight exp(−15/13.3) ≈ 0.32.
* γ = 0.5 < 1 makes the loss robust: large errors (a few particles that went astray)
  grow the loss only like √d, so they do not dominate the gradient, while small errors
  keep a steep gradient ∝ d^(−1/2) that drives the accurate steps further down.
* Unrolling ≥ 2 steps trains the network on its own output (the second step starts from
  x̂¹ and the finite-difference velocity v̂¹ = (x̂¹ − x⁰)/Δt, the state a rollout feeds it),
  which is what makes long rollouts stable; gradients reach step 1 through x̂¹ and v̂¹.
* The mean runs over each scene's particles, then over the scenes of the batch (each
  scene counts once, as in the reference code), so large scenes do not outweigh small ones.

The wall term (``loss.wall_weight`` λ > 0) adds to each step's loss::

    Lᵏ_wall = λ · mean_i ((max(0, m r − sᵢ))² + ε)^(γ/2) − ε^(γ/2),   sᵢ = (x̂ᵢᵏ − x_b)·n_b

with b the wall particle nearest to particle i among its wall neighbours at x* (the wall
conv's own search), n_b its normal (into the fluid) and m = ``loss.wall_margin`` particle
radii. The default m = 0 penalises only a centre behind the plane of its nearest wall
particle, which the SPH data never does (3e-5 of the particle-frames of the random training
scenes, none in the family scenes) while it keeps its first row within 1.5 r of the wall
particles on 5-6 % of them: a larger margin pulls against the data there (docs/models.md,
"Learning curves and ablations"). The position term alone does not
teach a network that a small error towards a wall is worse than one along it, and a
network rolled out alone drifts through walls by such errors.
"""
from __future__ import annotations

import numpy as np
import torch

from ..model.integrator import step
from ..neighbors import nearest_edges
from .config import LossConfig
from .sampler import Batch

EPS = 1e-9  # inside the root, as the reference: keeps the gradient finite at zero error


def neighbour_weights(counts, scale: float, like: torch.Tensor) -> torch.Tensor:
    """exp(−n / scale) per particle (1 everywhere when ``scale`` is 0)."""
    n = torch.as_tensor(np.asarray(counts), dtype=like.dtype, device=like.device)
    if scale <= 0:
        return torch.ones_like(n)
    return torch.exp(-n / scale)


def position_error(pred: torch.Tensor, target: torch.Tensor, gamma: float) -> torch.Tensor:
    """(‖pred − target‖² + ε)^(γ/2) per particle, [N]."""
    return (torch.sum((pred - target) ** 2, dim=1) + EPS) ** (0.5 * gamma)


def scene_mean(values: torch.Tensor, batch: Batch) -> torch.Tensor:
    """Mean over each scene's particles, then over the scenes that have any."""
    counts = torch.as_tensor(np.diff(batch.scenes.fluid), dtype=values.dtype,
                             device=values.device)
    sums = torch.zeros(len(counts), dtype=values.dtype, device=values.device)
    sums = sums.index_add(0, batch.scene_index(), values)
    has = counts > 0
    return (sums[has] / counts[has]).mean() if bool(has.any()) else values.sum() * 0


def phase_groups(batch: Batch) -> tuple[torch.Tensor, int]:
    """(group of every particle [N], number of groups): one group per scene and rest density."""
    key = np.stack([batch.scene_index().cpu().numpy().astype(np.float64),
                    batch.density.detach().cpu().numpy().astype(np.float64)], axis=1)
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = np.asarray(group).reshape(-1)
    return torch.as_tensor(group, device=batch.position.device), int(group.max()) + 1


def phase_error(pred: torch.Tensor, target: torch.Tensor, groups: tuple[torch.Tensor, int],
                gamma: float) -> torch.Tensor:
    """mean over (scene, phase) groups of (‖mean_group (pred − target)‖² + ε)^(γ/2)."""
    group, n = groups
    d = pred - target
    sums = torch.zeros(n, d.shape[1], dtype=d.dtype, device=d.device).index_add(0, group, d)
    counts = torch.bincount(group, minlength=n).to(d.dtype).unsqueeze(1)
    mean = sums / counts
    return ((mean ** 2).sum(dim=1) + EPS).pow(0.5 * gamma).mean()


def nearest_wall(geometry, wall_x, like: torch.Tensor) -> tuple[np.ndarray, np.ndarray]:
    """For each receiver of a wall→fluid conv ``geometry``: (particles with a wall neighbour
    [M], the nearest of their wall neighbours [M]), distances taken at the receivers'
    positions ``like`` [N, d] (detached)."""
    rec = geometry.receivers()
    snd = geometry.sender.astype(np.int64)
    if len(rec) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    xr = like.detach().cpu().numpy()[rec]
    ws = torch.as_tensor(wall_x).detach().cpu().numpy().astype(np.float64)[snd]
    pick = nearest_edges(rec, ((xr - ws) ** 2).sum(axis=1))
    return rec[pick].astype(np.int64), snd[pick]


def wall_penalty(x: torch.Tensor, batch: Batch, geometry, radius: float, margin: float,
                 gamma: float) -> torch.Tensor:
    """Per particle [N]: ((max(0, m r − s))² + ε)^(γ/2) − ε^(γ/2) with s the distance of the
    centre in front of its nearest wall particle along that particle's normal (module doc);
    0 for particles without a wall neighbour."""
    out = torch.zeros(len(x), dtype=x.dtype, device=x.device)
    if batch.wall_position is None or len(batch.wall_position) == 0:
        return out
    i, b = nearest_wall(geometry, batch.wall_position, x)
    if len(i) == 0:
        return out
    b = torch.as_tensor(b, device=x.device)
    wx = batch.wall_position[b].to(x.dtype)
    wn = batch.wall_normal[b].to(x.dtype)
    s = ((x[i] - wx) * wn).sum(dim=1)
    depth = torch.relu(margin * radius - s)
    pen = (depth ** 2 + EPS) ** (0.5 * gamma) - EPS ** (0.5 * gamma)
    return out.index_add(0, torch.as_tensor(i, device=x.device), pen)


def unrolled_loss(model, batch: Batch, cfg: LossConfig) -> tuple[torch.Tensor, list[float]]:
    """(L, [L¹, …, L^U]) of ``batch`` for ``model`` (a network or its DDP wrapper)."""
    net = getattr(model, "module", model)
    x, v = batch.position[0], batch.velocity
    total, parts = None, []
    groups = phase_groups(batch) if cfg.phase_weight > 0 else None
    for k, w in enumerate(cfg.weights()):
        x, v = step(model, x, v, batch.density, batch.wall_position, batch.wall_normal,
                    gravity=batch.gravity, scenes=batch.scenes)
        counts = np.diff(net.last_context.fluid.row_splits)
        err = neighbour_weights(counts, cfg.neighbor_scale, x) * \
            position_error(x, batch.position[k + 1], cfg.gamma)
        if cfg.wall_weight > 0:
            err = err + cfg.wall_weight * wall_penalty(
                x, batch, net.last_context.wall, net.cfg.particle_radius, cfg.wall_margin,
                cfg.gamma)
        lk = scene_mean(err, batch)
        if groups is not None:
            lk = lk + cfg.phase_weight * phase_error(x, batch.position[k + 1], groups, cfg.gamma)
        parts.append(float(lk.detach()))
        total = w * lk if total is None else total + w * lk
    return total, parts
