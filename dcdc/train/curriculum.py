"""The training curriculum as data (paper §3.4): "starting with single-phase simulations
and gradually introducing multi-density scenarios with increasing density ratios".

Each trajectory is ranked by its maximum density ratio ρ_max / ρ_min over the particles it
holds (:func:`max_density_ratio`). A stage allows the trajectories whose ratio is at most
its ``max_ratio`` until ``until`` × optim.steps; the allowed set only grows, so earlier
(lower-ratio) scenes stay in the mix and are not forgotten. After the last stage every
training trajectory is used.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..configs import check

SINGLE_PHASE_TOL = 1e-6  # a ratio within this of 1 counts as single phase


@dataclass
class Stage:
    """Until ``until`` × optim.steps, train only on trajectories with max ratio ≤ ``max_ratio``."""

    until: float = 0.2
    max_ratio: float = 1.0


@dataclass
class CurriculumConfig:
    """Stages in order of ``until``; their ``max_ratio`` must not fall. ``stages = []``
    turns the curriculum off (all trajectories from the first step)."""

    stages: list[Stage] = field(default_factory=lambda: [
        Stage(0.15, 1.0), Stage(0.35, 2.0), Stage(0.6, 5.0)])

    def validate(self):
        prev_until, prev_ratio = 0.0, 1.0
        for i, s in enumerate(self.stages):
            check(prev_until < s.until <= 1, f"curriculum.stages[{i}].until",
                  f"in ({prev_until:g}, 1] (stages in order)", s.until)
            check(s.max_ratio >= prev_ratio, f"curriculum.stages[{i}].max_ratio",
                  f">= {prev_ratio:g} (ratios rise, 1 = single phase)", s.max_ratio)
            prev_until, prev_ratio = s.until, s.max_ratio

    def stage_at(self, step: int, steps: int) -> tuple[int, float | None]:
        """(stage index, ratio cap) of 0-based ``step``; (len(stages), None) after the last."""
        for i, s in enumerate(self.stages):
            if step < s.until * steps:
                return i, s.max_ratio
        return len(self.stages), None


def max_density_ratio(traj) -> float:
    """ρ_max / ρ_min of a trajectory: its ``max_density_ratio`` attribute when the dataset
    stores one, else computed from the rest densities of the particles it holds (emitted
    ones included once born within the trajectory)."""
    stored = traj.attrs.get("max_density_ratio")
    if stored not in (None, ""):
        return float(stored)
    rho = np.asarray(traj.density, dtype=np.float64)
    if len(rho):
        rho = rho[np.asarray(traj.birth) <= float(traj.time[-1]) + 1e-9]
    if len(rho) == 0:
        return 1.0
    return float(rho.max() / rho.min())


def allowed(ratios: np.ndarray, cap: float | None) -> np.ndarray:
    """Mask of trajectories a stage with ratio cap ``cap`` may use (None: all)."""
    ratios = np.asarray(ratios, dtype=np.float64)
    if cap is None:
        return np.ones(len(ratios), dtype=bool)
    return ratios <= cap * (1 + SINGLE_PHASE_TOL)
