"""Why a network rolled out alone (no wall contact) leaves its container: per trajectory,
the guard's stop (step, cause), the stopping particle's velocity before and after its last
step (a jump of metres per second in one step is a network output far outside the data,
not a slow drift), the ground truth's largest speed near that time, and how many ground-
truth particles the rollout guard's own wall test counts at worst (the teacher's floor).

    python benchmarks/wall_passing.py --model dcdc2d --data datasets/2d_su/valid [--json F]
"""
from __future__ import annotations

import argparse
import json

import numpy as np
import dcdc  # noqa: F401  (first: it sets the OpenMP wait policy torch reads on import)
import torch

from dcdc.data.dataset import Dataset
from dcdc.evaluate.rollout import Guard, NeuralSimulator, run
from dcdc.metrics import inside_walls


def diagnose(model, traj) -> dict:
    sim = NeuralSimulator(model, traj.system(0), guard=Guard(max_in_walls=0.01), contact=False)
    ro = run(sim, traj.n_frames - 1)
    gt_in = max(int(inside_walls(traj.position[f], traj.wall_x, traj.wall_n,
                                 2 * traj.radius).sum()) for f in range(traj.n_frames))
    row = {"trajectory": traj.name, "particles": traj.n_particles, "steps": ro.steps,
           "requested": traj.n_frames - 1, "stop_cause": ro.stopped.cause if ro.stopped else "",
           "in_walls_max": int(ro.in_walls.max()) if len(ro.in_walls) else 0,
           "truth_in_walls_max": gt_in}
    if ro.stopped is not None and ro.steps >= 1:
        i, k = ro.stopped.particle, ro.steps
        speed_gt = np.linalg.norm(traj.velocity[max(0, k - 2):k + 2], axis=2).max()
        row.update({"speed_before": float(np.linalg.norm(ro.velocity[k - 1][i])),
                    "speed_last": float(np.linalg.norm(ro.velocity[k][i])),
                    "truth_max_speed_near": float(speed_gt)})
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    torch.set_num_threads(1)
    rows = [diagnose(a.model, t) for t in Dataset(a.data)]
    print("| trajectory | N | steps | stop | in walls (max) | truth in walls (max) | "
          "speed before -> after the last step | truth's max speed |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        jump = (f"{r['speed_before']:.1f} -> {r['speed_last']:.1f} m/s" if "speed_last" in r
                else "-")
        near = f"{r['truth_max_speed_near']:.1f} m/s" if "speed_last" in r else "-"
        print(f"| {r['trajectory']} | {r['particles']} | {r['steps']}/{r['requested']} | "
              f"{r['stop_cause'] or '-'} | {r['in_walls_max']} | {r['truth_in_walls_max']} | "
              f"{jump} | {near} |")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
