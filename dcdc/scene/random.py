"""Random training scenes (docs/scenes.md): random containers (open boxes, bowls), a few
obstacles (spheres, cylinders, boxes, shipped meshes), 1-4 fluid blocks of 1-4 phases whose
densities come from a range with a bounded max/min ratio (the curriculum parameter), and
random initial velocities. The same seed and settings always give the same scene file.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import DcdcError, require
from ..particles import FRAME_DT

MESH_ASSETS = ("asset:rock.obj", "asset:wedge.obj", "asset:capsule.obj")
PALETTE = ["#d8322a", "#2fa33a", "#2f58d0", "#f2c230"]


@dataclass
class RandomSceneConfig:
    """Knobs of :func:`random_scene`.

    max_ratio / min_ratio bound ρ_max/ρ_min of the scene's phases (max_ratio = 1: one
    density); density_range bounds every density [kg/m³]; duration None draws 2-3 s.
    """

    dim: int = 2
    max_ratio: float = 10.0
    min_ratio: float = 1.0
    density_range: tuple = (500.0, 5000.0)
    duration: float | None = None
    max_blocks: int = 4
    max_speed: float = 1.0
    obstacles: bool = True
    radius: float = 0.025
    min_particles: int | None = None  # redraw scenes with fewer fluid particles (default 700 / 1200)
    size: float | None = None  # length scale of containers and obstacles (default 2-D: 2, 3-D: 1)
    tension: float = 0.0  # σ [N/m] between every pair of phases (the solver's default model); 0 = none

    @property
    def scale(self) -> float:
        """2-D scenes are drawn 2x larger than 3-D ones, so that at r = 2.5 cm they hold
        ~1 000-2 000 fluid particles (enough for collective flow) instead of 150-640."""
        return self.size if self.size is not None else (2.0 if self.dim == 2 else 1.0)

    def check(self):
        lo, hi = self.density_range
        require(self.dim in (2, 3), f"dim must be 2 or 3 (got {self.dim})")
        require(0 < lo <= hi, f"density range must satisfy 0 < min <= max (got {lo}, {hi})")
        require(self.max_ratio >= 1, f"--max-ratio must be >= 1 (got {self.max_ratio})")
        require(1 <= self.min_ratio <= self.max_ratio,
                f"--min-ratio must lie in [1, max-ratio] (got {self.min_ratio})")
        require(self.min_ratio <= hi / lo,
                f"--min-ratio {self.min_ratio} is impossible within densities {lo}..{hi}")
        require(1 <= self.max_blocks <= 4, "max_blocks must be 1..4")
        require(self.size is None or (math.isfinite(self.size) and self.size > 0),
                f"size must be > 0 (got {self.size})")
        require(math.isfinite(self.tension) and self.tension >= 0,
                f"--tension must be a finite σ >= 0 N/m (got {self.tension})")
        return self


def _snap(v, q):
    return float(np.round(np.round(np.asarray(v) / q) * q, 6))


def _densities(rng, n, cfg):
    lo, hi = cfg.density_range
    rmax = min(cfg.max_ratio, hi / lo)
    if n == 1:
        return [round(float(np.exp(rng.uniform(math.log(lo), math.log(hi)))), 1)]
    ratio = float(np.exp(rng.uniform(math.log(cfg.min_ratio), math.log(max(rmax, cfg.min_ratio)))))
    rho_min = float(np.exp(rng.uniform(math.log(lo), math.log(hi / ratio))))
    rho_max = rho_min * ratio
    mids = np.exp(rng.uniform(math.log(rho_min), math.log(rho_max), n - 2)).tolist()
    vals = [rho_min, rho_max] + mids
    rng.shuffle(vals)
    return [round(v, 1) for v in vals]


def random_scene(seed: int, cfg: RandomSceneConfig | None = None) -> dict:
    """A random scene as a plain dict in the scene-file layout (validated by realising it)."""
    from .format import Scene
    from .schema import validate
    cfg = (cfg or RandomSceneConfig()).check()
    rng = np.random.default_rng([int(seed), 0xDCDC])
    d = cfg.dim
    sp = 2 * cfg.radius
    for attempt in range(100):
        try:
            scene = _draw(rng, seed, cfg, sp)
            n = Scene(validate(scene, "", f"random seed {seed}")).realize().n_fluid
            if n >= (cfg.min_particles if cfg.min_particles is not None else (700 if d == 2 else 1200)):
                return scene
        except DcdcError:
            continue  # overlapping draw: try again with the same generator (reproducible)
    raise DcdcError(f"could not draw a valid random scene for seed {seed} in 100 attempts")


def _draw(rng, seed, cfg, sp) -> dict:
    d = cfg.dim
    k = cfg.scale
    walls, fluid = {}, []
    container = "bowl" if rng.uniform() < 0.2 else "box"
    # every container is closed by a lid (a box around it), so no splash leaves the domain
    if container == "box":
        W = _snap(k * (rng.uniform(1.0, 2.0) if d == 2 else rng.uniform(0.8, 1.4)), sp)
        H = _snap(k * rng.uniform(0.8, 1.4), sp)
        D = _snap(k * rng.uniform(0.6, 1.2), sp) if d == 3 else None
        lo = [0.0, 0.0] + ([0.0] if d == 3 else [])
        hi = [W, H] + ([D] if d == 3 else [])
        top = [W, _snap(H + 0.6 * k, sp)] + ([D] if d == 3 else [])
        walls["tank"] = {"shape": "box", "min": lo, "max": top, "hollow": True, "open_top": False}
        dom_lo, dom_hi = list(lo), list(top)
        region_lo, region_hi = np.array(lo), np.array(hi)
    else:
        R = _snap(k * (rng.uniform(0.6, 0.9) if d == 2 else rng.uniform(0.5, 0.7)), sp)
        c = [0.0, 0.0] + ([0.0] if d == 3 else [])
        walls["bowl"] = {"shape": "bowl", "center": c, "radius": R}
        m = _snap(0.3 * k, sp)
        dom_lo = [-R - m, -_snap(0.2 * k, sp)] + ([-R - m] if d == 3 else [])
        dom_hi = [R + m, R + _snap(0.6 * k, sp)] + ([R + m] if d == 3 else [])
        walls["box"] = {"shape": "box", "min": list(dom_lo), "max": list(dom_hi), "hollow": True,
                        "open_top": False}
        region_lo = np.array([-R, 0.0] + ([-R] if d == 3 else []))
        region_hi = np.array([R, R] + ([R] if d == 3 else []))
    ext = region_hi - region_lo
    # obstacles in the lower part of the container, at least 3 spacings from the container
    # walls and from each other (narrow gaps would trap single particles)
    n_obs = int(rng.integers(0, 3)) if cfg.obstacles else 0
    obstacle_boxes = []  # bounding boxes grown by 2 spacings, kept free of fluid
    gap = 3 * sp
    for k in range(n_obs):
        kind = str(rng.choice(["sphere", "cylinder", "box", "mesh"]))
        size = k * float(rng.uniform(0.08, 0.18))
        if kind == "sphere":
            spec = {"shape": "sphere", "radius": round(size, 3)}
            half = np.full(d, size)
        elif kind == "cylinder":
            hgt, axis = k * float(rng.uniform(0.2, 0.5)), int(rng.choice([1, 2] if d == 3 else [1]))
            spec = {"shape": "cylinder", "radius": round(size, 3), "height": round(hgt, 3), "axis": axis}
            half = np.full(d, size)
            half[axis] = hgt / 2
        elif kind == "box":
            half = np.round(k * rng.uniform(0.06, 0.18, d), 3)
            spec = {"shape": "box"}
        else:
            spec = {"shape": "mesh", "file": str(rng.choice(MESH_ASSETS)), "scale": round(size, 3)}
            half = np.full(d, 1.2 * size)
        if container == "box":
            lo_c = region_lo + half + gap
            hi_c = region_hi - half - gap
            hi_c[1] = lo_c[1] + 0.35 * ext[1]
            if np.any(hi_c <= lo_c):
                continue
            c = rng.uniform(lo_c, hi_c)
        else:
            A = np.zeros(d)
            A[1] = region_hi[1]  # centre of the bowl's sphere
            reach = (region_hi[1] - gap) - np.linalg.norm(half)
            if reach <= 0:
                continue
            u = rng.normal(size=d)
            u[1] = -abs(u[1]) - 0.5
            c = A + u / np.linalg.norm(u) * rng.uniform(0, reach)
            if c[1] + half[1] > 0.9 * region_hi[1]:
                continue
        if any(np.all(c - half - gap < bh) and np.all(c + half + gap > bl) for bl, bh in obstacle_boxes):
            continue
        c = np.round(c, 3)
        obstacle_boxes.append((c - half - 2 * sp, c + half + 2 * sp))
        cl = [float(v) for v in c]
        if kind == "box":
            spec.update({"min": [round(float(v), 3) for v in c - half],
                         "max": [round(float(v), 3) for v in c + half]})
        elif kind == "mesh":
            spec["translate"] = cl + [0.0] * (3 - d)
        else:
            spec["center"] = cl
        walls[f"obstacle{k}"] = spec
    # fluid blocks: disjoint lattice-aligned boxes (fills of the bowl)
    n_phases_min = 2 if cfg.min_ratio > 1 else 1
    choices = np.arange(max(1, n_phases_min), cfg.max_blocks + 1)
    weights = np.where(choices == 1, 0.4, 1.0)
    n_blocks = int(rng.choice(choices, p=weights / weights.sum()))
    if cfg.max_ratio > 1 and n_blocks >= 2 and (n_phases_min == 2 or rng.uniform() < 0.85):
        n_phases = int(rng.integers(2, min(n_blocks, 4) + 1))
    else:
        n_phases = 1
    dens = _densities(rng, n_phases, cfg)
    names = [f"phase{i}" for i in range(n_phases)]
    phases = {n: {"density": rho, "viscosity": float(f"{np.exp(rng.uniform(np.log(1e-6), np.log(1e-4))):.3g}"),
                  "color": PALETTE[i]} for i, (n, rho) in enumerate(zip(names, dens))}
    boxes = []
    for b in range(n_blocks):
        for _ in range(30):
            size = ext * rng.uniform(0.3, 0.7, d)
            size[1] = ext[1] * rng.uniform(0.25, 0.6)
            lo = region_lo + (ext - size) * rng.uniform(0, 1, d)
            lo = np.array([_snap(v, sp) for v in lo])
            hi = np.array([_snap(v, sp) for v in lo + size])
            if np.any(hi - lo < 3 * sp):
                continue
            if any(np.all(lo < bh) and np.all(hi > bl) for bl, bh in boxes + obstacle_boxes):
                continue
            boxes.append((lo, hi))
            break
    for i, (lo, hi) in enumerate(boxes):
        ph = names[i] if i < n_phases else names[int(rng.integers(n_phases))]
        vel = [round(float(v), 3) for v in rng.uniform(-cfg.max_speed, cfg.max_speed, d)]
        blk = {"phase": ph, "velocity": vel, "min": [float(v) for v in lo], "max": [float(v) for v in hi]}
        if container == "box":
            blk["shape"] = "box"
        else:
            blk["shape"] = "fill"
            blk["inside"] = "bowl"
        fluid.append(blk)
    used = {f["phase"] for f in fluid}
    phases = {k: v for k, v in phases.items() if k in used}
    if not fluid or len(phases) < n_phases_min:
        raise DcdcError("no room for the fluid blocks")
    duration = cfg.duration if cfg.duration is not None else round(float(rng.uniform(2.0, 3.0)) / FRAME_DT) * FRAME_DT
    ratio = max(p["density"] for p in phases.values()) / min(p["density"] for p in phases.values())
    solver = {}
    if cfg.tension > 0 and len(phases) > 1:
        used_names = list(phases)
        solver["interfacial_tension"] = {f"{a}/{b}": float(cfg.tension)
                                         for i, a in enumerate(used_names) for b in used_names[i + 1:]}
    if len(phases) > 1 and not cfg.min_ratio * (1 - 1e-6) <= ratio <= cfg.max_ratio * (1 + 1e-6):
        raise DcdcError("a block with an extreme density found no room")
    return {
        "name": f"random_{seed}",
        "description": (f"random scene: seed {seed}, {d}-D, {container}, {len(phases)} phase(s), "
                        f"density ratio {ratio:.2f} (max-ratio {cfg.max_ratio:g}, min-ratio {cfg.min_ratio:g}, "
                        f"densities {cfg.density_range[0]:g}..{cfg.density_range[1]:g})"),
        "dim": d, "radius": cfg.radius, "duration": round(duration, 4), "seed": int(seed),
        "domain": {"min": dom_lo, "max": dom_hi},
        "phases": phases, "walls": walls, "fluid": fluid,
        **({"solver": solver} if solver else {}),
    }


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        r = repr(float(round(float(v), 9)))
        return r if ("." in r or "e" in r or "inf" in r or "nan" in r) else r + ".0"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def _toml_key(k: str) -> str:
    """A TOML key: bare when it is letters, digits, '_' and '-', else quoted (e.g. "a/b")."""
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def to_toml(scene: dict, header: str = "") -> str:
    """Scene dict -> TOML text in the layout of the built-in scene files (one-line arrays,
    [section] / [phases.NAME] / [walls.NAME] tables, [[fluid]] / [[emitter]] arrays)."""
    out = [header] if header else []
    for k, v in scene.items():
        if not isinstance(v, (dict, list)) or (isinstance(v, list) and not (v and isinstance(v[0], dict))):
            out.append(f"{k} = {_toml_value(v)}")
    for k, v in scene.items():
        if isinstance(v, dict):
            nested = v and all(isinstance(x, dict) for x in v.values()) and k != "solver"
            if nested:
                for name, t in v.items():
                    out.append(f"\n[{k}.{name}]")
                    out += [f"{a} = {_toml_value(b)}" for a, b in t.items()]
            else:
                out.append(f"\n[{k}]")
                out += [f"{a} = {_toml_value(b)}" for a, b in v.items()]
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for t in v:
                out.append(f"\n[[{k}]]")
                out += [f"{a} = {_toml_value(b)}" for a, b in t.items()]
    return "\n".join(out) + "\n"


def random_scene_text(seed: int, cfg: RandomSceneConfig | None = None) -> str:
    """The scene file text of :func:`random_scene`."""
    cfg = cfg or RandomSceneConfig()
    s = random_scene(seed, cfg)
    hdr = (f"# generated by `dcdc scene random --seed {seed} --dim {cfg.dim} --max-ratio {cfg.max_ratio:g}"
           f" --min-ratio {cfg.min_ratio:g} --density-range {cfg.density_range[0]:g} {cfg.density_range[1]:g}"
           + (f" --tension {cfg.tension:g}" if cfg.tension else "") + "`")
    return to_toml(s, hdr)
