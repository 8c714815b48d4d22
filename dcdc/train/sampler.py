"""Training windows: which ones (by the curriculum's density-ratio cap), augmentation, and
one concatenated batch for a single forward pass.

* A window is ``unroll + 1`` consecutive frames of one trajectory: frame 0 is the input
  (positions, velocities), frames 1.. the targets of the unrolled steps. Only particles
  present at frame 0 (``birth`` ≤ its time) take part.
* Batches are a pure function of (seed, step): a resumed run draws exactly the windows
  the interrupted one would have, and every rank of a DDP run draws the same batch and
  keeps its shard ``windows[rank::world]``.
* Augmentation: in 3-D a random rotation about the gravity axis, in 2-D a
  random mirror across it (the only isometry of the plane that keeps gravity); optional
  Gaussian noise on the input positions; optionally (:func:`push_into_walls`) a share of
  the particles beside a wall moved behind it in the input, the target left as it is.
* :func:`collate` concatenates the windows into one batch with
  :class:`~dcdc.model.networks.Scenes` offsets: the network's search runs scene by scene,
  so particles of different scenes never interact, and everything after it is one pass.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..data.dataset import Dataset
from ..errors import DcdcError
from ..model.networks import Scenes
from ..neighbors import nearest_edges, radius_search
from ..particles import TIME_EPS, active_mask
from .curriculum import allowed, max_density_ratio


def dataset_info(ds: Dataset, label: str) -> dict:
    """dim / radius / frame_dt shared by every trajectory of ``ds`` (else DcdcError)."""
    if len(ds) == 0:
        raise DcdcError(f"{label} {ds.path} holds no finished trajectory")
    vals = {}
    for key in ("dim", "radius", "frame_dt"):
        got = sorted({round(float(getattr(t, key)), 9) for t in ds})
        if len(got) > 1:
            raise DcdcError(f"{label} {ds.path} mixes trajectories with {key} "
                            f"{', '.join(f'{g:g}' for g in got)}; train on one at a time")
        vals[key] = got[0]
    vals["dim"] = int(vals["dim"])
    return vals


WALL_NOISE_REACH = 2.0  # particle radii: the particles data.wall_noise may move (first row)


class WindowSampler:
    """Windows of ``length`` frames of a dataset, drawn under a curriculum."""

    def __init__(self, ds: Dataset, length: int, stride: int = 1, seed: int = 0,
                 early_fraction: float = 0.0, early_frames: int = 10):
        self.ds, self.length, self.seed = ds, length, seed
        self.early_fraction, self.early_frames = float(early_fraction), int(early_frames)
        self.windows = np.array(ds.windows(length, stride), dtype=np.int64).reshape(-1, 2)
        if len(self.windows) == 0:
            raise DcdcError(f"{ds.path}: no trajectory has the {length} frames a training "
                            f"window needs (loss.unroll + 1)")
        self.ratios = np.array([max_density_ratio(t) for t in ds])
        self._win_ratio = self.ratios[self.windows[:, 0]]

    def eligible(self, cap: float | None) -> np.ndarray:
        """Indices (into :attr:`windows`) a stage with ratio cap ``cap`` may draw."""
        return np.flatnonzero(allowed(self._win_ratio, cap))

    def check_stages(self, caps) -> None:
        """Every curriculum stage must select at least one window."""
        for i, cap in enumerate(caps):
            if len(self.eligible(cap)) == 0:
                raise DcdcError(
                    f"curriculum stage {i} (max_ratio {cap:g}) selects no trajectory of "
                    f"{self.ds.path} (its density ratios are {self.ratios.min():.3g}–"
                    f"{self.ratios.max():.3g}); raise the stage's max_ratio")

    def batch(self, step: int, size: int, cap: float | None) -> list[tuple[int, int]]:
        """The (trajectory, start) windows of ``step`` (a pure function of seed and step)."""
        pool = self.eligible(cap)
        rng = np.random.default_rng([self.seed, step])
        pick = pool[rng.choice(len(pool), size=size, replace=size > len(pool))]
        if self.early_fraction > 0:
            early = pool[self.windows[pool, 1] < self.early_frames]
            swap = rng.random(size) < self.early_fraction
            if len(early) and swap.any():
                pick[swap] = early[rng.choice(len(early), size=int(swap.sum()))]
        return [tuple(int(v) for v in self.windows[k]) for k in pick]

    def fixed(self, n: int) -> list[tuple[int, int]]:
        """``n`` windows spread evenly over the dataset (validation)."""
        idx = np.unique(np.linspace(0, len(self.windows) - 1, num=min(n, len(self.windows)))
                        .round().astype(np.int64))
        return [tuple(int(v) for v in self.windows[k]) for k in idx]


def load_window(ds: Dataset, traj: int, start: int, length: int) -> dict:
    """One window as float64 arrays, restricted to the particles present at ``start``."""
    t = ds[traj]
    w = t.window(start, length)
    # present at the start and not removed before the window's last frame (a removed
    # particle is frozen where it left: no target for the network)
    live = active_mask(w["birth"], w.get("death"), float(w["time"][0]))
    if w.get("death") is not None:
        live &= np.asarray(w["death"]) > float(w["time"][-1]) + TIME_EPS
    return {"position": np.asarray(w["position"], np.float64)[:, live],
            "velocity": np.asarray(w["velocity"][0], np.float64)[live],
            "density": np.asarray(w["density"], np.float64)[live],
            "wall_position": np.asarray(w["wall_position"], np.float64).reshape(-1, t.dim),
            "wall_normal": np.asarray(w["wall_normal"], np.float64).reshape(-1, t.dim),
            "gravity": np.asarray(w["gravity"], np.float64)[:t.dim]}


def augment(sample: dict, rng: np.random.Generator, rotate: bool, noise_std: float,
            wall_depth: float = 0.0, wall_fraction: float = 0.0, wall_reach: float = 0.0) -> dict:
    """Rotate (3-D) / mirror (2-D) about the gravity axis; noise on the input positions;
    with ``wall_depth`` > 0, :func:`push_into_walls` on the (noisy) input positions."""
    s = dict(sample)
    d = s["position"].shape[-1]
    g = s["gravity"]
    if rotate and np.linalg.norm(g) > 0:
        M = _gravity_isometry(g / np.linalg.norm(g), d, rng)
        for k in ("position", "velocity", "wall_position", "wall_normal"):
            s[k] = s[k] @ M.T
    if noise_std > 0:
        s["position"] = s["position"].copy()
        s["position"][0] += rng.normal(scale=noise_std, size=s["position"][0].shape)
    if wall_depth > 0 and wall_fraction > 0 and len(s["wall_position"]):
        s["position"] = s["position"].copy()
        s["position"][0] = push_into_walls(s["position"][0], s["wall_position"],
                                           s["wall_normal"], rng, wall_depth, wall_fraction,
                                           wall_reach)
    return s


def push_into_walls(x: np.ndarray, wall_x: np.ndarray, wall_n: np.ndarray,
                    rng: np.random.Generator, depth: float, fraction: float,
                    reach: float) -> np.ndarray:
    """Input positions with a share of the particles beside a wall moved behind it: each
    particle whose nearest wall particle b lies within ``reach`` is, with probability
    ``fraction``, moved along −n_b to u·``depth`` behind b's tangent plane (u ~ U(0, 1))::

        x_i ← x_i − ((x_i − x_b)·n_b + u·depth) n_b

    The window's targets stay the teacher's frames, so the network learns to put a particle
    that has drifted into a wall back in front of it: the SPH data never holds one (the
    teacher's contact keeps every particle out), and a network that never saw one lets a
    slow drift into a wall go on (docs/models.md, "Generalisation suite"). Noise injection
    aimed at the one state a rollout must not reach (Sanchez-Gonzalez et al. 2020 inject
    noise for the same reason: the network sees its own errors' states in training)."""
    nb = radius_search(x, reach, wall_x)
    if nb.n_edges == 0:
        return x
    rec = nb.receivers()
    off = x[rec] - wall_x[nb.index]
    first = nearest_edges(rec, np.einsum("ij,ij->i", off, off))
    i, b = rec[first].astype(np.int64), nb.index[first].astype(np.int64)
    pick = rng.random(len(i)) < fraction
    u = rng.random(len(i))
    i, b, u = i[pick], b[pick], u[pick]
    n = wall_n[b] / np.maximum(np.linalg.norm(wall_n[b], axis=1, keepdims=True), 1e-12)
    s = np.einsum("ij,ij->i", x[i] - wall_x[b], n)
    out = x.copy()
    out[i] -= (s + u * depth)[:, None] * n
    return out


def _gravity_isometry(axis: np.ndarray, d: int, rng) -> np.ndarray:
    """A random orthogonal map that keeps ``axis`` (unit gravity direction) fixed."""
    if d == 2:  # mirror across the gravity line with probability 1/2
        return (2 * np.outer(axis, axis) - np.eye(2)) if rng.random() < 0.5 else np.eye(2)
    theta = rng.uniform(0, 2 * np.pi)  # Rodrigues' rotation about ``axis``
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * (K @ K)


@dataclass
class Batch:
    """Concatenated windows: ``position`` [L, N, d] (frame 0 = input), the rest per particle."""

    position: torch.Tensor
    velocity: torch.Tensor
    density: torch.Tensor
    wall_position: torch.Tensor
    wall_normal: torch.Tensor
    gravity: torch.Tensor  # [N, d]: each particle's scene gravity
    scenes: Scenes

    @property
    def n_particles(self) -> int:
        return int(self.position.shape[1])

    def scene_index(self) -> torch.Tensor:
        """Scene of every particle, int64 [N]."""
        counts = np.diff(self.scenes.fluid)
        return torch.repeat_interleave(torch.arange(len(counts), device=self.position.device),
                                       torch.as_tensor(counts, device=self.position.device))


def collate(samples: list[dict], dtype=torch.float32, device="cpu") -> Batch:
    """One :class:`Batch` of ``samples`` (their particles and walls concatenated)."""
    def cat(key, axis=0):
        return torch.as_tensor(np.concatenate([s[key] for s in samples], axis=axis),
                               dtype=dtype, device=device)

    grav = np.concatenate([np.broadcast_to(s["gravity"], s["velocity"].shape) for s in samples])
    return Batch(cat("position", axis=1), cat("velocity"), cat("density"),
                 cat("wall_position"), cat("wall_normal"),
                 torch.as_tensor(grav, dtype=dtype, device=device),
                 Scenes.from_counts([len(s["density"]) for s in samples],
                                    [len(s["wall_position"]) for s in samples]))
