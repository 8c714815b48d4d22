"""Interfacial tension between phase pairs from a pairwise repulsion (docs/sph.md).

Pairwise-force SPH (Tartakovsky & Meakin 2005; Tartakovsky & Panchenko 2016, "Pairwise
Force Smoothed Particle Hydrodynamics model for multiphase flow", J. Comput. Phys. 305)
makes interfaces from pair potentials u_ab(r) between particles. For a sharp interface
between two bulk phases of number density n, the interfacial energy per area is the change
in pair energy across it (Kirkwood & Buff 1949):

    σ_ab = -n² I [(k_aa + k_bb)/2 - k_ab],    I = ∫_across φ = π ∫_0^h φ(r) r³ dr (3-D),
                                                    2 ∫_0^h φ(r) r² dr (2-D),

with u_ab = k_ab φ and φ(r) = -∫_r^h w(s/h) ds <= 0 the potential of the shape w (the
cubic spline scaled to w(0) = 1). We keep k_aa = 0 (no cohesion, so no tension at a free
surface and no attraction that could clump particles) and set k_ab = σ_ab / (n² I) < 0: a
repulsion between unlike particles whose strength follows from σ_ab, not from a fit.
Checked against the Young-Laplace pressure jump of a 2-D and a 3-D droplet
(`dcdc validate-sph --case laplace`).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import DcdcError
from .kernels import cubic_values, sigma


def _potential(h: float, n: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """φ(r) = -∫_r^h w(s/h) ds tabulated at ``n`` points of [0, h] (trapezoidal rule), with
    w the cubic spline scaled to w(0) = 1 (:func:`dcdc.sph.kernels.cubic_values` / σ)."""
    r = np.linspace(0.0, h, n)
    w = cubic_values(r, h, 3)[0] / sigma(h, 3)
    seg = 0.5 * (w[1:] + w[:-1]) * np.diff(r)
    return r, -np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])


def across_integral(h: float, dim: int) -> float:
    """I of the module doc for the support ``h`` (trapezoidal quadrature); I < 0."""
    r, phi = _potential(h)
    if dim == 3:
        return float(math.pi * np.trapezoid(phi * r ** 3, r))
    return float(2.0 * np.trapezoid(phi * r ** 2, r))


def lattice_across_sum(radius: float, h: float, dim: int) -> float:
    """S = (1/A) Σ_{i above, j below} φ(|x_i - x_j|) over the rest lattice cut by a plane
    between two rows: the discrete counterpart of n² I (the pairs closer than one spacing
    that dominate the continuous integral do not exist on the lattice; S ≈ 0.52 n² I at
    h = 4r). S < 0."""
    s = 2.0 * radius
    m = int(math.ceil(h / s)) + 1
    tang = np.arange(-m, m + 1) * s
    below = -radius - s * np.arange(m)
    r, phi = _potential(h)
    total = 0.0
    for row in range(m):
        P = np.stack(np.meshgrid(*([tang, below] + [tang] * (dim - 2)), indexing="ij"),
                     axis=-1).reshape(-1, dim)
        P[:, 1] -= radius + s * row
        total += float(np.interp(np.linalg.norm(P, axis=1), r, phi, right=0.0).sum())
    return total / s ** (dim - 1)


def pair_coefficients(tensions: dict, phases, h: float, V0: float, dim: int) -> np.ndarray | None:
    """The matrix k_ab [N] (None when no pair has a tension) from ``tensions``: a mapping
    "a/b" (phase names) -> σ_ab [N/m] (in 2-D: per unit depth)."""
    if not tensions:
        return None
    names = [p.name for p in phases]
    K = np.zeros((len(names), len(names)))
    S = lattice_across_sum(V0 ** (1.0 / dim) / 2.0, h, dim)
    for key, sigma in tensions.items():
        parts = str(key).split("/")
        if len(parts) != 2 or parts[0] == parts[1]:
            raise DcdcError(f"sph.interfacial_tension: key {key!r} must name two different "
                            "phases as \"a/b\"")
        for p in parts:
            if p not in names:
                raise DcdcError(f"sph.interfacial_tension: {key!r} names no phase {p!r} "
                                f"(phases: {', '.join(names)})")
        a, b = names.index(parts[0]), names.index(parts[1])
        K[a, b] = K[b, a] = float(sigma) / S
    return K
