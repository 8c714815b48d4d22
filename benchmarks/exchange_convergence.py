"""Exchange flows under refinement and under the numerical dissipation (issue 8, item 2).

The two exchange flows the project ships, each at three or four particle radii and with the
solver's stabilisation at full strength (the defaults: XSPH ε = 0.1, artificial viscosity
1e-3 m²/s), at half strength, and switched off:

* the full-depth 2-D lock exchange of ``dcdc validate-sph --case lock_exchange``
  (1500 | 1000 kg/m³, 1.6 × 0.2 m closed tank): Froude numbers of the heavy (floor) and
  light (lid) fronts, Fr = U / sqrt(g'H), fitted over t = 2-5 T0
  (:func:`dcdc.sph.experiments.lock_exchange_run`); energy-conserving theory ½ (Benjamin 1968);
* the built-in 2-D hourglass (2500 over 1000 kg/m³, 15 s) at the scene's radius 2.5 cm,
  1.77 cm and 1.25 cm: the fraction of the heavy phase below the neck (y < 0.9 m) at
  5, 10 and 15 s and the time at which half of it has passed.

    python benchmarks/exchange_convergence.py [--quick] [--json benchmarks/results/exchange_convergence.json]

``--quick`` runs only the two coarsest radii of each; ``--hourglass-radii`` other radii;
``--only``, ``--settings`` and
``--seeds 1 2 …`` (ensemble members with a 1 mm/s random start, both flows),
``--lock-radii`` and ``--viscous-nu`` (the "viscous" setting: no XSPH, that viscosity) select parts.
``--closed`` starts every setting from the closed-container settings instead of the defaults
(the hydrostatic reference of the light phase, a tenth of the damping:
:func:`dcdc.sph.reference.closed_container`, what the built-in closed scenes use; the hourglass's convergence without tension in
``benchmarks/results/exchange_convergence_hourglass_closed.json``).
Prints a table; the JSON holds every number and the wall times. The hourglass exchange is
chaotic: single runs of numerically equal settings differ by several % in the drained
fraction, so compare ensembles.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import time

import numpy as np

from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.experiments import LOCK_RHO, lock_exchange_run
from dcdc.sph.reference import closed_container

NECK_Y = 0.9  # the hourglass neck: half the 1.8 m cavity


def settings(base: SPHConfig, viscous_nu: float = 2.6e-3) -> dict[str, SPHConfig]:
    """The stabilisation at full strength, halved, and off; "viscous": no XSPH and a
    viscosity ``viscous_nu`` (docs/sph.md: the defaults' effective viscosity at 5 mm)."""
    d = base.to_dict()
    return {"default": base,
            "half": SPHConfig.from_dict({**d, "xsph": 0.5 * base.xsph, "viscosity": 0.5 * base.viscosity}),
            "off": SPHConfig.from_dict({**d, "xsph": 0.0, "viscosity": 0.0}),
            "viscous": SPHConfig.from_dict({**d, "xsph": 0.0, "viscosity": viscous_nu})}


def lock(r: float, cfg: SPHConfig, seed: int = 0) -> dict:
    d = lock_exchange_run(r, cfg, seed=seed)
    return {"r": r, "n": d["n"], "seed": seed, "depth": d["H"], "fr_heavy": d["fr_heavy"],
            "fr_light": d["fr_light"], "wall_s": d["wall"]}


def hourglass(r: float, cfg_over: dict, seed: int = 0) -> dict:
    """The 2-D hourglass at particle radius ``r`` with the scene's own solver table plus
    ``cfg_over``; the heavy fraction below the neck every frame. ``seed`` > 0 adds a random
    initial velocity of 1 mm/s rms per component (an ensemble member of the chaotic neck
    flow); 0 is the scene as it is."""
    base = get_scene("hourglass")
    scene = dataclasses.replace(base, data={**base.data, "radius": r}, _cache={})
    sy = scene.realize(2)
    if seed:
        sy.v += 1e-3 * np.random.default_rng(seed).standard_normal(sy.v.shape)
    cfg = SPHConfig.from_dict({**scene.solver, **cfg_over})
    heavy = [p.name for p in sy.phases].index("heavy")
    sim = Simulator(sy, cfg)
    t0 = time.perf_counter()
    ts, below = [], []
    n = int(round(scene.duration / 0.02))
    for _ in range(n):
        sim.advance(0.02)
        ts.append(sim.time)
        below.append(float(np.mean(sy.x[sy.phase == heavy, 1] < NECK_Y)))
    below = np.array(below)
    half = np.flatnonzero(below >= 0.5)
    at = lambda t: float(below[int(round(t / 0.02)) - 1])  # noqa: E731
    return {"r": r, "n": sy.n_fluid, "seed": seed, "below_5s": at(5.0), "below_10s": at(10.0),
            "below_15s": at(15.0), "below_end": float(below[-1]), "duration": scene.duration,
            "t_half": float(ts[half[0]]) if len(half) else None,
            "wall_s": time.perf_counter() - t0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument("--closed", action="store_true",
                    help="start from the closed-container settings (reference, a tenth of the damping)")
    ap.add_argument("--only", choices=["lock", "hourglass"], default=None)
    ap.add_argument("--seeds", type=int, nargs="*", default=[0],
                    help="hourglass ensemble members (0 = unperturbed; see hourglass())")
    ap.add_argument("--settings", nargs="*", default=["default", "half", "off"],
                    choices=["default", "half", "off", "viscous"])
    ap.add_argument("--viscous-nu", type=float, default=2.6e-3,
                    help="viscosity of the 'viscous' setting [m²/s]")
    ap.add_argument("--lock-radii", type=float, nargs="*", default=None,
                    help="lock-exchange particle radii [m] (default 0.01 0.007 0.005 0.0035)")
    ap.add_argument("--hourglass-radii", type=float, nargs="*", default=None,
                    help="hourglass particle radii [m] (default 0.025 0.0177 0.0125)")
    a = ap.parse_args()
    lock_r = [0.01, 0.007] if a.quick else [0.01, 0.007, 0.005, 0.0035]
    hg_r = [0.025, 0.0177] if a.quick else [0.025, 0.0177, 0.0125]
    if a.hourglass_radii:
        hg_r = a.hourglass_radii
    if a.lock_radii:
        lock_r = a.lock_radii
    base = (SPHConfig.from_dict(closed_container(SPHConfig().to_dict(), LOCK_RHO[1])) if a.closed
            else SPHConfig())
    # the hourglass with --closed: its own scene settings (reference 900, closed damping)
    base_hg = (SPHConfig.from_dict({**SPHConfig().to_dict(), **get_scene("hourglass").solver})
               if a.closed else SPHConfig())
    cfgs = {k: v for k, v in settings(base, a.viscous_nu).items() if k in a.settings}
    cfgs_hg = {k: v for k, v in settings(base_hg, a.viscous_nu).items() if k in a.settings}
    doc = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
           "numba_threads": os.environ.get("NUMBA_NUM_THREADS", "default"),
           "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
           "base": base.to_dict(), "base_hourglass": base_hg.to_dict(), "lock_exchange": [],
           "hourglass": []}
    if a.only in (None, "lock"):
        print(f"{'lock exchange':<14} {'r mm':>5} {'seed':>4} {'N':>6} {'Fr heavy':>9} "
              f"{'Fr light':>9} {'wall s':>7}")
        for name, cfg in cfgs.items():
            for r, seed in [(r, k) for r in lock_r for k in a.seeds]:
                if name == "half" and r < 0.005:
                    continue  # the halving is read at 5 mm, as in validate-sph
                row = {"setting": name, **lock(r, cfg, seed)}
                doc["lock_exchange"].append(row)
                print(f"{name:<14} {r * 1e3:>5.1f} {seed:>4} {row['n']:>6} {row['fr_heavy']:>9.3f} "
                      f"{row['fr_light']:>9.3f} {row['wall_s']:>7.1f}", flush=True)
    if a.only in (None, "hourglass"):
        print(f"{'hourglass':<14} {'r mm':>5} {'seed':>4} {'N':>6} {'below 5 s':>9} {'10 s':>6} {'15 s':>6} "
              f"{'end':>6} {'t half':>7} {'wall s':>7}")
        for name, cfg in cfgs_hg.items():
            over = cfg.to_dict()  # the whole setting, not the scene's own [solver] table
            for r, seed in [(r, k) for r in hg_r for k in a.seeds]:
                row = {"setting": name, **hourglass(r, over, seed)}
                doc["hourglass"].append(row)
                th = f"{row['t_half']:.2f}" if row["t_half"] is not None else "-"
                print(f"{name:<14} {r * 1e3:>5.1f} {seed:>4} {row['n']:>6} {row['below_5s']:>9.3f} "
                      f"{row['below_10s']:>6.3f} {row['below_15s']:>6.3f} {row['below_end']:>6.3f} {th:>7} "
                      f"{row['wall_s']:>7.1f}", flush=True)
    doc["finished"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    if a.json:
        with open(a.json, "w") as f:
            json.dump(doc, f, indent=2)
            f.write("\n")


if __name__ == "__main__":
    main()
