"""Particle set-ups of the SPH validation (:mod:`dcdc.sph.cases`) and its experiments
(:mod:`dcdc.sph.experiments`): a tank of wall particles (:func:`dcdc.geometry.sample_walls` on
:func:`dcdc.geometry.shapes.container`) holding blocks of fluid on the rest lattice, and the
`laplace` case's drop in a closed box."""
from __future__ import annotations

import math

import numpy as np

from ..geometry import lattice, sample_walls
from ..geometry.shapes import container
from ..particles import ParticleSystem, Phase


G = 9.81


def tank_system(dim: int, r: float, size, blocks, phases: list[Phase], wall_height=None,
                name: str = "tank", closed: bool = False) -> ParticleSystem:
    """Tank with inner box [0, size] (walls ``wall_height`` tall; a lid there if ``closed``,
    which keeps the jets of a 10:1 collapse in the tank) and fluid blocks.

    ``blocks``: list of (lo, hi, phase_of) where ``phase_of(points) -> phase index or -1``
    may split a block between phases (or drop points). Fluid sits on the lattice
    ``r + 2r·k`` so that the first layer is one spacing from the wall particles."""
    s = 2.0 * r
    size = np.asarray(size, dtype=np.float64)[:dim]
    lo = np.zeros(dim)
    top = np.array(size)
    top[1] = size[1] if wall_height is None else wall_height
    xs, ph = [], []
    for blo, bhi, phase_of in blocks:
        pts = lattice(np.asarray(blo, float)[:dim] + r, np.asarray(bhi, float)[:dim] - r, s,
                      anchor=lo + r)
        idx = np.asarray(phase_of(pts), dtype=np.int64)
        keep = idx >= 0
        xs.append(pts[keep])
        ph.append(idx[keep])
    x = np.concatenate(xs)
    phase = np.concatenate(ph)
    sdf = container(lo - r, top + r, open_top=not closed)
    pad = 2 * s + 0.5 * r
    whi = top + r + pad
    if not closed:
        whi[1] = top[1] + r
    wx, wn = sample_walls(sdf, lo - r - pad, whi, s, 2 * s, anchor=lo - r)
    dom_lo = lo - 2 * s - 0.05
    dom_hi = top + 2 * s + 0.05
    dom_hi[1] = top[1] + 2.0
    gravity = np.array([0.0, -G, 0.0])[:dim]
    # the tank's inner box (the wall face lies half a spacing outside the first fluid layer),
    # for exporters such as dcdc.sph.splishsplash
    meta = {"container": (lo.tolist(), top.tolist())}
    # the solid for the walls' volume map: its surface is the tank's inner box, where the
    # fluid's lattice cells end (the wall particles' sampling surface lies r further out)
    solid = container(lo, top, open_top=not closed)
    return ParticleSystem(dim, r, x, np.zeros_like(x), phase, phases, wx, wn, gravity,
                          (dom_lo, dom_hi), name=name, meta=meta, wall_sdf=solid)


def case_radius(dim: int, quick: bool) -> float:
    """Particle radius of the multiphase cases: quick 2.5 cm, full 1.25 cm (4-6 k particles
    in the 0.2 m deep 3-D tanks). At 2 cm the 3-D tanks were 5 particles deep, and in the
    10:1 collapse single light particles squeezed out between the heavy front and the wall
    reached 9.7 m/s; at 1.25 cm the fastest particle stayed at 3.0 m/s (measured)."""
    return 0.025 if quick else 0.0125


def one_phase(i):
    return lambda pts: np.full(len(pts), i)


def tank_size(dim, w, h, depth):
    return [w, h, depth][:dim]


def closed_tank(dim: int, quick: bool, W: float, H: float, phases: list[Phase], assign,
                 name: str):
    """A closed tank of inner size W × H (× 0.2 deep in 3-D, walls 2H + 0.2 tall) filled with
    one block whose particles ``assign`` maps to phase indices; its Simulator and floor area."""
    size = tank_size(dim, W, H, 0.2)
    sy = tank_system(dim, case_radius(dim, quick), size,
                     [(np.zeros(3), size + [0] * (3 - dim), assign)], phases,
                     wall_height=2 * H + 0.2, name=name, closed=True)
    return sy, float(np.prod(np.delete(size, 1)))


def jitter(sy: ParticleSystem, seed: int) -> None:
    """An ensemble member's start: ``seed`` > 0 adds a random velocity of 1 mm/s rms per
    component (seed 0: the start at rest, unchanged)."""
    if seed:
        sy.v += 1e-3 * np.random.default_rng(seed).standard_normal(sy.v.shape)


def laplace_box(dim: int) -> float:
    """Side [m] of the `laplace` case's closed box: 0.4 in 2-D, 0.3 in 3-D."""
    return 0.4 if dim == 2 else 0.3


def laplace_half(dim: int) -> float:
    """Half side [m] of the `laplace` case's square (cube) drop: the area of a disc of radius
    0.1 m (the volume of a sphere of 0.09 m)."""
    return 0.5 * (math.sqrt(math.pi) * 0.1 if dim == 2 else (4.0 * math.pi / 3.0) ** (1 / 3) * 0.09)


def laplace_drop(dim: int, r: float, densities: tuple = (1000.0, 1000.0)) -> ParticleSystem:
    """The `laplace` case's start: a square (cube) drop of phase "drop" (a disc of radius
    0.1 m / a sphere of 0.09 m by volume) in the middle of a closed box (:func:`laplace_box`)
    filled with phase "ambient", densities (ambient, drop) [kg/m³], gravity off."""
    W = laplace_box(dim)
    half = laplace_half(dim)
    c = W / 2
    inside = lambda p: np.where((np.abs(p - c) < half).all(1), 1, 0)  # noqa: E731
    phases = [Phase("ambient", float(densities[0])), Phase("drop", float(densities[1]))]
    size = [W] * dim
    sy = tank_system(dim, r, size, [(np.zeros(3), size + [0] * (3 - dim), inside)], phases,
                     wall_height=W, name="laplace", closed=True)
    sy.gravity[:] = 0.0
    return sy
