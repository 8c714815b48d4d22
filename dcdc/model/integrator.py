"""Algorithm 1 of the paper: inertial step, neural correction, velocity from positions.

One step with time step Δt and gravity g (docs/model.md, "Integrator")::

    v* = v + Δt g                      (inertial velocity)
    x* = x + Δt (v + v*) / 2           (eq. 2: x + Δt v + ½ Δt² g)
    Δx = net(x*, v*, ρ, walls)         (eq. 3, the network sees the advanced state as in CConv)
    x' = x* + Δx                       (Algorithm 1, line 8)
    v' = (x' − x) / Δt                 (Algorithm 1, line 9)

:func:`step` is differentiable w.r.t. the network parameters and the input velocities (the
neighbour geometry is recomputed from x* and treated as data), so a training loop can unroll
it; :func:`rollout` runs it without gradients. Argument names follow the dataset's
vocabulary (``position``, ``velocity``, ``density``, ``wall_position``, ``wall_normal``,
``gravity``: :meth:`dcdc.data.dataset.Trajectory.window`).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
import torch

from ..errors import DcdcError
from ..particles import DEFAULT_GRAVITY



def _gravity(gravity, dim: int, like: torch.Tensor) -> torch.Tensor:
    """Gravity as a [d] vector, or [N, d] rows (one per particle, for batches of scenes)."""
    g = DEFAULT_GRAVITY if gravity is None else gravity
    g = torch.as_tensor(np.asarray(g) if not isinstance(g, torch.Tensor) else g,
                        dtype=like.dtype, device=like.device)
    if g.ndim == 2:
        if g.shape != like.shape:
            raise DcdcError(f"per-particle gravity must be [{like.shape[0]}, {dim}] "
                            f"(got {list(g.shape)})")
        return g
    return g.reshape(-1)[:dim]


def inertial(x: torch.Tensor, v: torch.Tensor, dt: float, gravity=None):
    """(x*, v*): the inertial prediction of eq. 2."""
    g = _gravity(gravity, x.shape[1], x)
    v_star = v + dt * g
    return x + 0.5 * dt * (v + v_star), v_star


def step(model, position, velocity, density, wall_position=None, wall_normal=None,
         dt: float | None = None, gravity=None, scenes=None):
    """One neural step; returns (position, velocity) as tensors in the model's dtype.

    The argument names are those of :meth:`dcdc.data.dataset.Trajectory.window`, so a
    window's frame can be passed as ``step(net, **inputs)``.

    Args:
        model: a :class:`~dcdc.model.networks.CorrectionNet` (or a DDP wrapper of one).
        position, velocity: [N, d] positions and velocities (tensors or arrays).
        density: [N] per-particle rest densities [kg/m³] (> 0).
        wall_position, wall_normal: [M, d] wall particles and normals (optional).
        dt: time step [s]; default the model's ``frame_dt``.
        gravity: [d] vector (default (0, −9.81, 0) cut to d) or [N, d] per particle.
        scenes: :class:`~dcdc.model.networks.Scenes` when the arrays concatenate several
            scenes (one forward pass; particles of different scenes never interact).
    """
    net = getattr(model, "module", model)  # a DistributedDataParallel wrapper: its network
    p = next(net.parameters())
    dt = net.cfg.frame_dt if dt is None else dt
    x = torch.as_tensor(position).to(dtype=p.dtype, device=p.device)
    v = torch.as_tensor(velocity).to(dtype=p.dtype, device=p.device)
    _check_inputs(net, x, v, density, wall_position, wall_normal, dt)
    x_star, v_star = inertial(x, v, dt, gravity)
    dx = model(x_star, v_star, density, wall_position, wall_normal, scenes=scenes)
    x_new = x_star + dx
    return x_new, (x_new - x) / dt


def _check_inputs(model, x, v, density, wall_x, wall_n, dt) -> None:
    """One-line errors for inputs that would otherwise give NaN or a shape traceback."""
    d = model.dim
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise DcdcError(f"time step dt must be a finite number > 0 (got {dt!r})")
    if x.ndim != 2 or x.shape[1] != d:
        raise DcdcError(f"a {d}-D network needs positions [N, {d}] (got {list(x.shape)})")
    if v.shape != x.shape:
        raise DcdcError(f"velocities {list(v.shape)} do not match positions {list(x.shape)}")
    n_rho = int(np.prod(density.shape)) if hasattr(density, "shape") else len(density)
    if n_rho != x.shape[0]:
        raise DcdcError(f"density has {n_rho} values for {x.shape[0]} particles")
    rho = density if isinstance(density, torch.Tensor) else torch.as_tensor(np.asarray(density))
    if x.shape[0] and not bool((rho > 0).all() & torch.isfinite(rho).all()):
        raise DcdcError("densities must be finite and > 0 (kg/m³)")
    if wall_x is not None:
        ws = tuple(wall_x.shape)
        if len(ws) != 2 or ws[1] != d:
            raise DcdcError(f"a {d}-D network needs wall positions [M, {d}] (got {list(ws)})")
        if wall_n is not None and tuple(wall_n.shape) != ws:
            raise DcdcError(f"wall normals {list(wall_n.shape)} do not match wall positions {list(ws)}")


@torch.no_grad()
def rollout(model, position, velocity, density, wall_position=None, wall_normal=None,
            n_steps: int = 1, dt: float | None = None, gravity=None,
            callback: Callable[[int, torch.Tensor, torch.Tensor], None] | None = None):
    """``n_steps`` steps without gradients; ``callback(k, x, v)`` after each. Returns (x, v)."""
    x, v = position, velocity
    for k in range(n_steps):
        x, v = step(model, x, v, density, wall_position, wall_normal, dt, gravity)
        if callback is not None:
            callback(k, x, v)
    return x, v


def system_inputs(system) -> dict:
    """Keyword arguments of :func:`step` / :func:`rollout` from a
    :class:`~dcdc.particles.ParticleSystem`: position, velocity, density (per-particle rest
    density), wall_position, wall_normal, gravity.

    Emitted particles (``birth`` > t) are the caller's business: select the live ones first.
    """
    return {"position": torch.from_numpy(system.x), "velocity": torch.from_numpy(system.v),
            "density": torch.from_numpy(system.rest_density),
            "wall_position": system.wall_x, "wall_normal": system.wall_n,
            "gravity": torch.from_numpy(system.gravity)}
