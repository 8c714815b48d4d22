"""The Young-Laplace jump of the "curvature" interfacial tension model under refinement,
σ and density ratio (docs/sph.md, "Interfacial tension"): runs
:func:`dcdc.sph.experiments.laplace_run` (the `laplace` validation drop, 2.5 s, no gravity) for
each variant and prints a table; ``--json`` writes it.

    python benchmarks/laplace_curvature.py --json benchmarks/results/laplace_curvature.json
"""
from __future__ import annotations

import argparse
import json
import platform
import time

from dcdc.sph.experiments import laplace_run
from dcdc.sph.config import SPHConfig

# (dim, r [m], σ [N/m], (ambient, drop) densities [kg/m³], model)
VARIANTS = [
    (2, 0.01, 10.0, (1000, 1000), "curvature"),
    (2, 0.005, 10.0, (1000, 1000), "curvature"),
    (2, 0.0025, 10.0, (1000, 1000), "curvature"),
    (2, 0.01, 5.0, (1000, 1000), "curvature"),
    (2, 0.01, 20.0, (1000, 1000), "curvature"),
    (2, 0.01, 10.0, (1000, 2000), "curvature"),
    (2, 0.01, 10.0, (1000, 100), "curvature"),
    (2, 0.01, 10.0, (100, 1000), "curvature"),
    (3, 0.0125, 10.0, (1000, 1000), "curvature"),
    (3, 0.01, 10.0, (1000, 1000), "curvature"),
    (3, 0.0125, 20.0, (1000, 1000), "curvature"),
    (3, 0.0125, 10.0, (1000, 2000), "curvature"),
    (3, 0.01, 10.0, (1000, 2000), "curvature"),
    (3, 0.0125, 10.0, (1000, 100), "curvature"),
    (3, 0.0125, 10.0, (100, 1000), "curvature"),
    (2, 0.01, 10.0, (1000, 1000), "pairwise"),
    (3, 0.0125, 10.0, (1000, 1000), "pairwise"),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--only-dim", type=int, choices=(2, 3))
    args = ap.parse_args()
    rows = []
    print(f"{'dim':>3} {'r [mm]':>6} {'σ':>5} {'ρ amb/drop':>11} {'model':>9} {'N':>6} "
          f"{'R/h':>5} {'Δp/YL':>6} {'max r/R':>7} {'wall s':>6}")
    for dim, r, sig, dens, model in VARIANTS:
        if args.only_dim and dim != args.only_dim:
            continue
        cfg = SPHConfig(interfacial_model=model)
        t0 = time.perf_counter()
        m = laplace_run(dim, r, cfg, sigma=sig, densities=dens)
        wall = time.perf_counter() - t0
        row = {"dim": dim, "radius": r, "sigma": sig, "densities": list(dens), "model": model,
               "N": m["N"], "R_over_h": m["R"] / (cfg.support * r), "jump": m["jump"],
               "max_radius": m["shape"], "wall_s": wall}
        rows.append(row)
        print(f"{dim:>3} {r * 1e3:>6.1f} {sig:>5.0f} {dens[0]:>5}/{dens[1]:<5} {model:>9} "
              f"{m['N']:>6} {row['R_over_h']:>5.2f} {m['jump']:>6.3f} {m['shape']:>7.3f} "
              f"{wall:>6.1f}", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": platform.processor() or platform.machine(),
                       "duration_s": 2.5, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
