"""Particle-size drops leaving a wall (docs/sph.md, "Walls for the pairwise tension"):
single light particles (700 kg/m³, every sixth of the floor row; 3-D: also every fourth
across) under a 0.4 m column of 2000 kg/m³, r = 2.5 cm, the "pairwise" tension σ between
them (wall images on); the share that rose more than two spacings and the median rise after
3 s, per σ. Fritz (1935): a drop on a 90° wall departs above Bo = Δρ g D²/σ ≈ 3.5
(D = 2r: Bo = 31.9 / σ here).

    python benchmarks/drop_departure.py --dim 2 2 5 6 7 8.5 10 20 > benchmarks/drop_departure.jsonl
    python benchmarks/drop_departure.py --dim 3 5 10 20 >> benchmarks/drop_departure.jsonl

Measured in session 28 (idle machine, both commands 40 s): 2-D all rise at 2 / 5 / 6 / 8.5
N/m, none at 7 / 10 / 20; 3-D all at 5, 7 of 8 at 10, none at 20.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from dcdc.particles import Phase
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.cases import tank_system

R, WIDTH, DEPTH, T = 0.025, 0.6, 0.4, 3.0


def drops(dim: int, sigma: float) -> dict:
    size = [WIDTH, DEPTH + 0.1] + ([0.2] if dim == 3 else [])

    def fill(p):
        pick = (p[:, 1] < 2 * R) & (np.abs((p[:, 0] / (2 * R)) % 6 - 3) < 0.6)
        if dim == 3:
            pick &= np.abs((p[:, 2] / (2 * R)) % 4 - 2) < 0.6
        return np.where(pick, 1, np.where(p[:, 1] > DEPTH, -1, 0))
    sy = tank_system(dim, R, size, [(np.zeros(3), size + [0] * (3 - dim), fill)],
                     [Phase("heavy", 2000.0), Phase("light", 700.0)], name="drops")
    light = sy.phase == 1
    y0 = sy.x[light, 1].copy()
    cfg = {"interfacial_tension": {"heavy/light": sigma}, "interfacial_model": "pairwise"}
    Simulator(sy, SPHConfig.from_dict(cfg if sigma > 0 else {})).run(T, 0.02)
    rise = sy.x[light, 1] - y0
    bond = 1300.0 * 9.81 * (2 * R) ** 2 / sigma if sigma > 0 else float("inf")
    return {"dim": dim, "sigma": sigma, "bond": round(bond, 2), "drops": int(light.sum()),
            "risen": float(np.mean(rise > 4 * R)), "median_rise_r": round(float(np.median(rise)) / R, 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("sigma", type=float, nargs="+", help="σ [N/m]; 0: no tension")
    args = ap.parse_args()
    for s in args.sigma:
        print(json.dumps(drops(args.dim, s)), flush=True)


if __name__ == "__main__":
    main()
