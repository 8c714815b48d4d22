"""The thin-film row of `dcdc validate-sph --case thin_film`, with its resolution series and
the damping switched off (docs/sph.md, "Why light fluid stays under heavy fluid").

    python benchmarks/thin_film.py [--json benchmarks/results/thin_film.json]

A 2 cm film of light fluid (1000 kg/m³) on the floor under a 2:1 heavier fluid, its top
perturbed by a cosine, rises (Rayleigh-Taylor) alike under 0.3 m and under 0.12 m of heavy
fluid in an incompressible fluid; the script reports the rise of the light phase's mean
height after 1 s under both, per resolution and setting.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time

from dcdc.sph import SPHConfig
from dcdc.sph.experiments import FILM, film_pair

RUNS = [  # (label, dim, r, settings)
    ("2-D r 10 mm (quick)", 2, 0.01, {}),
    ("2-D r 5 mm (full)", 2, 0.005, {}),
    ("2-D r 2.5 mm", 2, 0.0025, {}),
    ("2-D r 5 mm, xsph 0, viscosity 0", 2, 0.005, {"xsph": 0.0, "viscosity": 0.0}),
    ("3-D r 10 mm (quick)", 3, 0.01, {}),
    ("3-D r 7.5 mm (full)", 3, 0.0075, {}),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    out = {"machine": f"{platform.machine()}, {os.cpu_count()} cores", "film": FILM,
           "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "runs": []}
    print(f"{'run':<34} {'N deep':>7} {'rise deep [mm]':>15} {'rise 0.12 m [mm]':>17} "
          f"{'ratio':>7} {'left deep':>10} {'left 0.12 m':>12} {'wall s':>7}")
    for label, dim, r, settings in RUNS:
        cfg = SPHConfig.from_dict(settings)
        t0 = time.perf_counter()
        pair = film_pair(dim, r, cfg)
        wall = time.perf_counter() - t0
        deep, shallow, ratio = pair["deep"], pair["shallow"], pair["ratio"]
        out["runs"].append({"run": label, "dim": dim, "r": r, "settings": settings, **pair,
                            "wall_s": wall})
        print(f"{label:<34} {deep['n']:>7} {1e3 * deep['rise']:>15.2f} "
              f"{1e3 * shallow['rise']:>17.2f} {ratio:>7.3f} {deep['left']:>10.3f} "
              f"{shallow['left']:>12.3f} {wall:>7.0f}", flush=True)
    out["finished"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
