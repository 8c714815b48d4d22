"""The lock exchange's start-to-start noise and what holds its coarse fronts (docs/sph.md,
"Closed containers", "The resolution a current needs"): ten starts of
:func:`dcdc.sph.experiments.lock_exchange_run` at r = 10 mm with the closed settings and with their
damping halved (the paired change of each start), then six starts each with one setting
changed (time step, solver tolerances, interface damping, kernel support 5 / 3.5 / 3).

    python benchmarks/lock_exchange_starts.py --json benchmarks/results/lock_exchange_starts_10mm.json

About 4 min on 2 cores.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from dcdc.sph.experiments import LOCK_RHO, halved_damping, lock_exchange_run
from dcdc.sph.reference import closed_container
from dcdc.sph.config import SPHConfig

R = 0.01
VARIANTS = [{"cfl": 0.2}, {"density_tolerance": 1e-4, "divergence_tolerance": 1e-4},
            {"interface_damping": False}, {"support": 5}, {"support": 3.5}, {"support": 3}]


def fronts(cfg: SPHConfig, seed: int) -> tuple[float, float]:
    d = lock_exchange_run(R, cfg, seed=seed)
    return d["fr_heavy"], d["fr_light"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the runs here")
    args = ap.parse_args()
    closed = closed_container(SPHConfig().to_dict(), LOCK_RHO[1])
    cfg, half = SPHConfig.from_dict(closed), halved_damping(closed)
    rows = []
    for seed in range(10):
        (h, l), (hh, lh) = fronts(cfg, seed), fronts(half, seed)
        rows.append({"seed": seed, "fr_heavy": h, "fr_light": l, "fr_heavy_halved": hh,
                     "fr_light_halved": lh})
        print(seed, round(h, 3), round(l, 3), round(hh, 3), round(lh, 3), flush=True)
    a = np.array([[r["fr_heavy"], r["fr_light"], r["fr_heavy_halved"], r["fr_light_halved"]]
                  for r in rows])
    change = a[:, 2] / a[:, 0] - 1
    print(f"means {a.mean(0).round(4)}, sd {a.std(0, ddof=1).round(4)}; paired heavy change "
          f"{change.mean():+.4f} (sd {change.std(ddof=1):.4f}); ratio of means "
          f"{a[:, 2].mean() / a[:, 0].mean() - 1:+.4f}")
    variants = []
    for over in VARIANTS:
        f = np.array([fronts(SPHConfig.from_dict({**closed, **over}), k) for k in range(6)])
        fr, se = f.mean(0), f.std(0, ddof=1) / np.sqrt(len(f))
        variants.append({"change": over, "fr": fr.round(3).tolist(), "se": se.round(3).tolist()})
        print(json.dumps(over), fr.round(3), se.round(3), flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"what": "lock exchange 1.5:1, 2-D, r = 10 mm, closed settings "
                       "(dcdc.sph.experiments.lock_exchange_run, closed_container) and the same with "
                       "xsph and viscosity halved, seeds 0-9 (jitter)", "rows": rows,
                       "variants_6_starts": {"what": "the closed settings with one change, "
                                             "seeds 0-5, mean Fr heavy / light and their "
                                             "standard errors", "rows": variants}},
                      fh, indent=1)


if __name__ == "__main__":
    main()
