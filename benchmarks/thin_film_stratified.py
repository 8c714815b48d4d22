"""The thin-film row (``dcdc validate-sph --case thin_film``, full resolution) with the
layered reference (``reference_stratified = true``) and the share of each slab's lightest
density it takes out (:data:`dcdc.sph.reference.AUTO_REFERENCE`, 0.9; swept here by
replacing the share that :func:`dcdc.sph.reference.strata` is called with):

    python benchmarks/thin_film_stratified.py [--dim 2] [--shares 0.6 0.8 0.9 0.95 0.97] [--json OUT]

Prints, per share, the rise of the light phase in 1 s under 0.3 m and under 0.12 m of heavy
fluid and their ratio (the row passes within 0.67-1.5). Measured 2026-12-04 in
benchmarks/thin_film_stratified.json (docs/sph.md, "A reference that follows the layers").
"""
from __future__ import annotations

import argparse
import json
import time

from dcdc.sph import SPHConfig
from dcdc.sph import reference, solver
from dcdc.sph.cases import film_pair

FULL_RADIUS = {2: 0.005, 3: 0.0075}  # the row's full variant (dcdc.sph.cases.thin_film)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--shares", type=float, nargs="+", default=[0.6, 0.8, 0.9, 0.95, 0.97])
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    strata = reference.strata
    out = {"dim": a.dim, "radius": FULL_RADIUS[a.dim], "runs": []}
    print(f"{'share':>6} {'deep mm':>8} {'shallow mm':>10} {'ratio':>7} {'s':>5}")
    for share in a.shares:
        solver.strata = lambda *args, share=share, **kw: strata(*args, share=share)
        t = time.time()
        r = film_pair(a.dim, FULL_RADIUS[a.dim], SPHConfig(reference_stratified=True))
        row = {"share": share, "deep_rise_mm": 1e3 * r["deep"]["rise"],
               "shallow_rise_mm": 1e3 * r["shallow"]["rise"], "ratio": r["ratio"],
               "wall_s": time.time() - t}
        out["runs"].append(row)
        print(f"{share:6.2f} {row['deep_rise_mm']:8.1f} {row['shallow_rise_mm']:10.1f} "
              f"{row['ratio']:7.3f} {row['wall_s']:5.0f}", flush=True)
    solver.strata = strata
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
