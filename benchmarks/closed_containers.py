"""What the closed-container settings do where they are used (docs/sph.md, "Closed containers").

1. A closed, completely filled two-layer tank at rest (2-D, 0.6 × 0.2 m, heavy 1500 under
   light 1000, r = 10 mm, 3 s from the lattice): the mean particle speed / sqrt(gH) at the
   end and its largest value over the last 1.5 s, for the open-scene defaults and for the
   hydrostatic reference with the damping at full, a fifth, a tenth (the closed-container
   setting), a twentieth and none. This is the packing's restlessness that the damping is
   there to settle ("What the stabilisation is for").
2. The built-in hourglass in 3-D at its default resolution with its own (closed-container)
   settings: the heavy phase below the neck at 1, 2, 5, 10 and 15 s, the largest particle
   speed, the wall time.

    python benchmarks/closed_containers.py [--skip-3d] [--json benchmarks/results/closed_containers.json]

The lock exchange and the 2-D hourglass under these settings are in
``benchmarks/exchange_convergence.py --closed``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from dcdc.particles import Phase
from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.experiments import LOCK_RHO
from dcdc.sph.fixtures import G, tank_system
from dcdc.sph.measures import run
from dcdc.sph.reference import closed_container

sys.path.insert(0, str(Path(__file__).parent))
from exchange_convergence import NECK_Y  # noqa: E402  (the hourglass neck's height)


def tank_settings() -> dict[str, dict]:
    """The open-scene defaults and the reference with the damping scaled by 1, 1/5, 1/10
    (the closed-container setting), 1/20 and 0."""
    d = SPHConfig().to_dict()
    ref = closed_container(d, LOCK_RHO[1])
    out = {"defaults": d, "defaults, damping off": {**d, "xsph": 0.0, "viscosity": 0.0}}
    for name, f in (("reference, full damping", 1.0), ("reference, 1/5", 0.2),
                    ("reference, 1/10 (closed setting)", 0.1), ("reference, 1/20", 0.05),
                    ("reference, damping off", 0.0)):
        out[name] = {**ref, "xsph": f * d["xsph"], "viscosity": f * d["viscosity"]}
    return out


def tank_at_rest(settings: dict, r: float = 0.01, T: float = 3.0) -> dict:
    W, H = 0.6, 2 * r * round(0.2 / (2 * r))
    phases = [Phase("heavy", LOCK_RHO[0]), Phase("light", LOCK_RHO[1])]
    split = lambda p: np.where(p[:, 1] < H / 2, 0, 1)  # noqa: E731
    sy = tank_system(2, r, [W, H], [(np.zeros(3), [W, H, 0.0], split)], phases,
                     wall_height=H, name="rest", closed=True)
    sim = Simulator(sy, SPHConfig.from_dict(settings))
    speeds = []
    t0 = time.perf_counter()
    run(sim, T, lambda s, f: speeds.append(float(np.sqrt((s.system.v ** 2).sum(1)).mean())))
    u = math.sqrt(G * H)
    return {"n": sy.n_fluid, "speed_end": speeds[-1] / u,
            "speed_max_last_half": max(speeds[len(speeds) // 2:]) / u,
            "wall_s": time.perf_counter() - t0}


def hourglass_3d() -> dict:
    scene = get_scene("hourglass")
    sy = scene.realize(3, 1.0)
    sim = Simulator(sy, SPHConfig.from_dict(scene.solver))
    heavy = [p.name for p in sy.phases].index("heavy")
    out = {"n": sy.n_fluid, "settings": scene.solver, "below": {}}
    vmax, t0 = 0.0, time.perf_counter()
    for f in range(int(round(scene.duration / 0.02))):
        sim.advance(0.02)
        vmax = max(vmax, float(np.sqrt((sy.v ** 2).sum(1)).max()))
        t = round((f + 1) * 0.02, 6)
        if t in (1.0, 2.0, 5.0, 10.0, 15.0):
            out["below"][f"{t:g} s"] = float(np.mean(sy.x[sy.phase == heavy, 1] < NECK_Y))
    out.update(max_speed=vmax, wall_s=time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=None)
    ap.add_argument("--skip-3d", action="store_true")
    a = ap.parse_args()
    doc = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
           "numba_threads": os.environ.get("NUMBA_NUM_THREADS", "default"),
           "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "tank_at_rest": {}}
    print(f"{'closed two-layer tank at rest (r 10 mm, 3 s)':<48} {'speed/sqrt(gH) end':>19} "
          f"{'max last 1.5 s':>15}")
    for name, s in tank_settings().items():
        row = tank_at_rest(s)
        doc["tank_at_rest"][name] = {**row, "xsph": s["xsph"], "viscosity": s["viscosity"],
                                     "reference_density": s["reference_density"]}
        print(f"{name:<48} {row['speed_end']:>19.4f} {row['speed_max_last_half']:>15.4f}", flush=True)
    if not a.skip_3d:
        doc["hourglass_3d"] = hg = hourglass_3d()
        print(f"hourglass 3-D ({hg['n']} particles): heavy below the neck "
              + ", ".join(f"{k} {v:.3f}" for k, v in hg["below"].items())
              + f"; max speed {hg['max_speed']:.2f} m/s; {hg['wall_s']:.0f} s", flush=True)
    doc["finished"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    if a.json:
        with open(a.json, "w") as f:
            json.dump(doc, f, indent=1)


if __name__ == "__main__":
    main()
