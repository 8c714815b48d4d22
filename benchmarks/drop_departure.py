"""Particle-size drops leaving a wall (docs/sph.md, "Walls for the pairwise tension"):
single light particles (700 kg/m³, every sixth of the floor row; 3-D: also every fourth
across) under a 0.4 m column of 2000 kg/m³, r = 2.5 cm, the "pairwise" tension σ between
them (wall images on); the share that rose more than two spacings and the median rise after
3 s, per σ. Fritz (1935): a drop on a 90° wall departs above Bo = Δρ g D²/σ ≈ 3.5
(D = 2r: Bo = 31.9 / σ here).

    python benchmarks/drop_departure.py --dim 2 2 5 6 7 8.5 10 20 > benchmarks/results/drop_departure.jsonl
    python benchmarks/drop_departure.py --dim 3 5 10 20 >> benchmarks/results/drop_departure.jsonl

Measured in session 28 (idle machine, both commands 40 s): 2-D all rise at 2 / 5 / 6 / 8.5
N/m, none at 7 / 10 / 20; 3-D all at 5, 7 of 8 at 10, none at 20.
"""
from __future__ import annotations

import argparse
import json

from dcdc.sph.experiments import floor_drops_run


def drops(dim: int, sigma: float) -> dict:
    """One JSON line: :func:`dcdc.sph.experiments.floor_drops_run` over 3 s."""
    m = floor_drops_run(dim, sigma, T=3.0)
    return {"dim": dim, "sigma": sigma, "bond": round(m["bond"], 2), "drops": m["drops"],
            "risen": m["risen"], "median_rise_r": round(m["median_rise_r"], 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("sigma", type=float, nargs="+", help="σ [N/m]; 0: no tension")
    args = ap.parse_args()
    for s in args.sigma:
        print(json.dumps(drops(args.dim, s)), flush=True)


if __name__ == "__main__":
    main()
