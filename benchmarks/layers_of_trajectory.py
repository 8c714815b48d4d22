"""Density order, purity per phase (metrics.neighbour_purity_per_phase), the share of each
phase trapped at the walls under denser fluid (metrics.trapped_at_walls) and the densest
phase's pooled / inverted shares (metrics.pooled_heavy, the canyon's measure) of a stored
trajectory at the given times; one JSON line per time:

    python benchmarks/layers_of_trajectory.py datasets/3d_st/test_scenes cocktail_3d [5 10 15]
"""
import json
import sys

import numpy as np

from dcdc import metrics
from dcdc.data import Dataset


def main() -> None:
    path, name = sys.argv[1], sys.argv[2]
    times = [float(t) for t in sys.argv[3:]] or [5.0, 10.0, 15.0]
    traj = Dataset(path)[name]
    for t in times:
        frame = min(int(round(t / traj.frame_dt)), traj.n_frames - 1)
        sy = traj.system(frame)
        dens = np.array([p.density for p in sy.phases])
        layers = metrics.layer_summary(sy.x, sy.phase, dens, sy.wall_x, sy.radius)
        pooled = metrics.pooled_heavy(sy.x, sy.phase, dens, sy.wall_x, sy.radius)
        print(json.dumps({"trajectory": name, "t": round(frame * traj.frame_dt, 6),
                          "n": int(sy.n_fluid), "order": layers["order"],
                          "purity": layers["purity"].round(3).tolist(),
                          "trapped": layers["trapped"].round(4).tolist(),
                          "pooled_inverted": [round(float(v), 3) for v in pooled]}))


if __name__ == "__main__":
    main()
