"""The hourglass's measure read from a stored trajectory: the share of the heavy phase below
the neck (y < 0.9 m, half the built-in's 1.8 m cavity) at the given times, and the first
time half of it is through; one JSON line. The same measure as
``exchange_convergence.py``'s hourglass rows and ``tests/test_showcases.py``:

    python benchmarks/hourglass_of_trajectory.py datasets/3d_su/test_scenes hourglass_3d [5 10 15]
"""
import json
import sys

import numpy as np

from dcdc.data import Dataset
from exchange_convergence import NECK_Y  # the hourglass neck's height


def main() -> None:
    path, name = sys.argv[1], sys.argv[2]
    times = [float(t) for t in sys.argv[3:]] or [5.0, 10.0, 15.0]
    traj = Dataset(path)[name]
    heavy = traj.phase == [p.name for p in traj.phases].index("heavy")
    below = (traj.position[:, heavy, 1] < NECK_Y).mean(axis=1)  # per frame
    half = np.flatnonzero(below >= 0.5)
    at = {f"below_{t:g}s": round(float(below[min(int(round(t / traj.frame_dt)), traj.n_frames - 1)]), 4)
          for t in times}
    print(json.dumps({"trajectory": name, "n": int(traj.n_particles), **at,
                      "t_half": round(float(half[0] * traj.frame_dt), 3) if len(half) else None}))


if __name__ == "__main__":
    main()
