"""Algorithm 1 of the paper: inertial step, neural correction, velocity from positions.

One step with time step Δt and gravity g (DESIGN §4)::

    v* = v + Δt g                      (inertial velocity)
    x* = x + Δt (v + v*) / 2           (eq. 2: x + Δt v + ½ Δt² g)
    Δx = net(x*, v*, ρ, walls)         (eq. 3, the network sees the advanced state as in CConv)
    x' = x* + Δx                       (Algorithm 1, line 8)
    v' = (x' − x) / Δt                 (Algorithm 1, line 9)

:func:`step` is differentiable w.r.t. the network parameters and the input velocities (the
neighbour geometry is recomputed from x* and treated as data), so a training loop can unroll
it; :func:`rollout` runs it without gradients.
"""
from __future__ import annotations

from typing import Callable

import torch

from ..particles import DEFAULT_GRAVITY

DEFAULT_DT = 0.02  # s, one frame / one neural step (DESIGN §2)


def _gravity(gravity, dim: int, like: torch.Tensor) -> torch.Tensor:
    g = DEFAULT_GRAVITY if gravity is None else gravity
    g = torch.as_tensor(g, dtype=like.dtype, device=like.device).reshape(-1)
    return g[:dim]


def inertial(x: torch.Tensor, v: torch.Tensor, dt: float, gravity=None):
    """(x*, v*): the inertial prediction of eq. 2."""
    g = _gravity(gravity, x.shape[1], x)
    v_star = v + dt * g
    return x + 0.5 * dt * (v + v_star), v_star


def step(model, x, v, density, wall_x=None, wall_n=None, dt: float = DEFAULT_DT,
         gravity=None):
    """One neural step; returns (x_new, v_new) as tensors in the model's dtype.

    Args:
        model: a :class:`~dcdc.model.networks.CorrectionNet`.
        x, v: [N, d] positions and velocities (tensors or arrays).
        density: [N] per-particle rest densities.
        wall_x, wall_n: [M, d] wall particles and normals (optional).
        dt: time step [s]; gravity: vector (default (0, −9.81, 0) cut to d).
    """
    p = next(model.parameters())
    x = torch.as_tensor(x).to(dtype=p.dtype, device=p.device)
    v = torch.as_tensor(v).to(dtype=p.dtype, device=p.device)
    x_star, v_star = inertial(x, v, dt, gravity)
    dx = model(x_star, v_star, density, wall_x, wall_n)
    x_new = x_star + dx
    return x_new, (x_new - x) / dt


@torch.no_grad()
def rollout(model, x, v, density, wall_x=None, wall_n=None, n_steps: int = 1,
            dt: float = DEFAULT_DT, gravity=None,
            callback: Callable[[int, torch.Tensor, torch.Tensor], None] | None = None):
    """``n_steps`` steps without gradients; ``callback(k, x, v)`` after each. Returns (x, v)."""
    for k in range(n_steps):
        x, v = step(model, x, v, density, wall_x, wall_n, dt, gravity)
        if callback is not None:
            callback(k, x, v)
    return x, v


def system_inputs(system) -> dict:
    """Keyword arguments of :func:`step` / :func:`rollout` from a
    :class:`~dcdc.particles.ParticleSystem`: x, v, per-particle rest density, walls, gravity.

    Emitted particles (``birth`` > t) are the caller's business: select the live ones first.
    """
    return {"x": torch.from_numpy(system.x), "v": torch.from_numpy(system.v),
            "density": torch.from_numpy(system.rest_density),
            "wall_x": system.wall_x, "wall_n": system.wall_n,
            "gravity": torch.from_numpy(system.gravity)}
