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

NECK_Y = 0.9


def main() -> None:
    path, name = sys.argv[1], sys.argv[2]
    times = [float(t) for t in sys.argv[3:]] or [5.0, 10.0, 15.0]
    traj = Dataset(path)[name]
    heavy = [p.name for p in traj.system(0).phases].index("heavy")
    below = []
    for frame in range(traj.n_frames):
        sy = traj.system(frame)
        below.append(float(np.mean(sy.x[sy.phase == heavy, 1] < NECK_Y)))
    half = np.flatnonzero(np.array(below) >= 0.5)
    at = {f"below_{t:g}s": round(below[min(int(round(t / traj.frame_dt)), traj.n_frames - 1)], 4)
          for t in times}
    print(json.dumps({"trajectory": name, "n": int(traj.system(0).n_fluid), **at,
                      "t_half": round(float(half[0] * traj.frame_dt), 3) if len(half) else None}))


if __name__ == "__main__":
    main()
