"""The 2-D cocktail at the demo's resolution (2.0, ~1 700 particles, the scene's 15 s) from
its lattice start and from starts perturbed by 0.1 mm (seeds 1, 2, ...), with the solver
settings of the scene plus JSON overrides: density order, purity per phase and each phase's
share left at the glass under denser fluid (``dcdc.metrics.trapped_at_walls``; issue 8 asks
< 1 %):

    python benchmarks/cocktail_2d_starts.py '{}' 0 1 2 >> OUT.jsonl
    python benchmarks/cocktail_2d_starts.py '{"reference_surface": false}' 0 1 2 >> OUT.jsonl
    python benchmarks/cocktail_2d_starts.py --scale 3 '{}' 0 1 2 >> OUT.jsonl   # a larger glass

``--scale`` is the scene's length scale (``realize(2, scale)``: the same particle radius in a
larger glass; default 2.0, the demo's).

One JSON line per run. Measured 2026-12-04 in benchmarks/results/cocktail_2d_starts.jsonl
(docs/sph.md, "Known limits").
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from dcdc import metrics
from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig

PERTURBATION = 1e-4  # [m], Gaussian, on the particles present at the start


def run(overrides: dict, start: int, scale: float = 2.0) -> dict:
    scene = get_scene("cocktail")
    sy = scene.realize(2, scale)
    if start:
        rng = np.random.default_rng(start)
        sy.x += rng.normal(0.0, PERTURBATION, sy.x.shape) * (sy.birth <= 0)[:, None]
    t = time.time()
    Simulator(sy, SPHConfig.from_dict({**scene.solver, **overrides})).run(scene.data["duration"], 0.02)
    layers = metrics.layer_summary(sy.x, sy.phase, [p.density for p in sy.phases], sy.wall_x,
                                   sy.radius)
    return {"overrides": overrides, "start": start, "scale": scale, "particles": int(sy.n_fluid),
            "order": layers["order"],
            "purity": np.round(layers["purity"], 4).tolist(),
            "trapped": np.round(layers["trapped"], 4).tolist(),
            "phases": [p.name for p in sy.phases], "wall_s": round(time.time() - t, 1)}


def main(argv: list[str]) -> None:
    scale = 2.0
    if argv[:1] == ["--scale"]:
        scale, argv = float(argv[1]), argv[2:]
    overrides = json.loads(argv[0]) if argv else {}
    for start in (map(int, argv[1:]) if len(argv) > 1 else [0]):
        print(json.dumps(run(overrides, start, scale)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
