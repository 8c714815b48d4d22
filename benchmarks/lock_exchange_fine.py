"""The closed lock exchange one radius finer than the full validation table (docs/validation.md;
docs/sph.md, "The resolution a current needs"): three starts at r = 2.5 mm (12 800 particles) with the closed
settings, then each front's Froude number extrapolated to r -> 0 through the table's radii
(7 / 5 / 3.5 mm, read from ``benchmarks/results/validate_sph_2d.json``) and this one, to first and
second order (:func:`dcdc.sph.measures.extrapolate_to_zero`, equal weights: the table stores the
starts' spread, not their standard errors).

    python benchmarks/lock_exchange_fine.py --json benchmarks/results/lock_exchange_fine.json

About 4 min on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import re

from dcdc.sph.experiments import ENSEMBLE_SEEDS, LOCK_RHO, lock_exchange_ensemble
from dcdc.sph.measures import extrapolate_to_zero
from dcdc.sph.reference import closed_container
from dcdc.sph.config import SPHConfig

TABLE = "benchmarks/results/validate_sph_2d.json"


def table_fronts(path: str = TABLE) -> dict:
    """{r [m]: (Fr heavy, Fr light)} of the full table's per-radius rows."""
    with open(path) as fh:
        rows = json.load(fh)["rows"]
    out: dict = {}
    for row in rows:
        m = re.search(r"lock exchange 1.5:1 2D \(N=\d+, r=([\d.]+) mm\)", row["case"])
        if m and row["quantity"].startswith("Fr heavy front"):
            out.setdefault(float(m.group(1)) / 1000, [None, None])[0] = row["measured"]
        elif m and row["quantity"].startswith("Fr light front"):
            out.setdefault(float(m.group(1)) / 1000, [None, None])[1] = row["measured"]
    if not out or any(None in v for v in out.values()):
        raise SystemExit(f"error: {path} has no complete per-radius lock-exchange rows "
                         "(\"lock exchange 1.5:1 2D (N=…, r=… mm)\"): were the rows relabelled?")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--r", type=float, default=0.0025, help="the finer radius [m]")
    ap.add_argument("--json", help="write the result here")
    args = ap.parse_args()
    cfg = SPHConfig.from_dict(closed_container(SPHConfig().to_dict(), LOCK_RHO[1]))
    fine = lock_exchange_ensemble(args.r, cfg, ENSEMBLE_SEEDS)
    fronts = table_fronts()
    fronts[args.r] = [fine["fr_heavy"], fine["fr_light"]]
    radii = sorted(fronts, reverse=True)
    nan = [float("nan")] * len(radii)
    result = {"what": "closed lock exchange 1.5:1, 2-D, Fr per radius (the table's and this "
              "run's) and extrapolated to r -> 0", "fine": fine, "radii_m": radii,
              "fr": {f"{r * 1000:g} mm": fronts[r] for r in radii}, "extrapolated": {}}
    for k, name in enumerate(("heavy", "light")):
        values = [fronts[r][k] for r in radii]
        for order in (1, 2):
            for label, sel in (("all", slice(None)), ("finest three", slice(-3, None))):
                a, _ = extrapolate_to_zero(radii[sel], values[sel], nan[sel], order=order)
                result["extrapolated"][f"{name}, order {order}, {label}"] = a
    print(json.dumps(result, indent=1))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
