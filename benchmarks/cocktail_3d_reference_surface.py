"""The 3-D cocktail at its default resolution (8 048 particles, 15 s) with the scene's settings
plus the JSON overrides given (e.g. '{"reference_surface": true}'): density order, purity
per phase (metrics.neighbour_purity_per_phase) and the share of each phase trapped at the
glass under denser fluid (metrics.trapped_at_walls) at 5, 10 and 15 s; one JSON line each.

    python benchmarks/cocktail_3d_reference_surface.py '{}'
    python benchmarks/cocktail_3d_reference_surface.py '{"reference_surface": true}'

Measured 2026-12-04 in benchmarks/cocktail_3d_reference_surface.json (docs/sph.md); session 21's
default under the key "bodies_mixture_session21" (docs/sph.md, "A level per body of fluid"),
session 24's (suction) under "suction_session24".
"""
import json
import sys
import time

import numpy as np

from dcdc import metrics
from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig


def main() -> None:
    over = json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}
    scene = get_scene("cocktail")
    sy = scene.realize(3, 1.0)
    sim = Simulator(sy, SPHConfig.from_dict({**scene.solver, **over}))
    dens = np.array([p.density for p in sy.phases])
    t0 = time.perf_counter()
    out = {"over": over, "n": sy.n_fluid}
    for f in range(int(round(scene.duration / 0.02))):
        sim.advance(0.02)
        t = round((f + 1) * 0.02, 6)
        if t in (5.0, 10.0, 15.0):
            layers = metrics.layer_summary(sy.x, sy.phase, dens, sy.wall_x, sy.radius)
            out[f"{t:g}s"] = {"order": layers["order"], "purity": layers["purity"].round(3).tolist(),
                              "trapped": layers["trapped"].round(4).tolist()}
            print(json.dumps(out | {"wall": round(time.perf_counter() - t0)}), flush=True)


if __name__ == "__main__":
    main()
