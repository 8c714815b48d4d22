"""The SPH teacher against itself: how far apart two SPH runs of a built-in scene end when
their starts differ by EPS metres rms (the floor under a learned model's rollout error on a
chaotic flow; docs/evaluation.md, "Ensembles"). Member 0 is the stored start (its run should
repeat the stored trajectory), members 1..K-1 are displaced like ``dcdc evaluate --members``'
(seed k). At each given time: the COM height error of the member against the stored run
(the same definition as ``dcdc evaluate``'s, :func:`dcdc.evaluate.scores.compare_states`)
and the order; one JSON line per member and time:

    python benchmarks/sph_ensemble.py datasets/2d_su/test_scenes hourglass_2d --members 5 --times 5 10 15
"""
import argparse
import json
import time

import numpy as np

from dcdc.data import Dataset
from dcdc.evaluate.scores import compare_states, displace
from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data")
    ap.add_argument("trajectory", help="a built-in's stored run, e.g. hourglass_2d")
    ap.add_argument("--members", type=int, default=5)
    ap.add_argument("--first", type=int, default=0, help="first member (0 = the stored start)")
    ap.add_argument("--perturb", type=float, default=1e-6)
    ap.add_argument("--times", type=float, nargs="+", default=[5.0, 10.0, 15.0])
    ap.add_argument("--json", default=None, help="append the lines to this JSONL file too")
    a = ap.parse_args()
    traj = Dataset(a.data)[a.trajectory]
    name, dim = a.trajectory.rsplit("_", 1)
    scene = get_scene(name)
    frames = sorted({min(int(round(t / traj.frame_dt)), traj.n_frames - 1) for t in a.times})
    for k in range(a.first, a.members):
        sy = scene.realize(int(dim[0]), 1.0)
        if sy.n_fluid != traj.n_particles:
            raise SystemExit(f"{name}: {sy.n_fluid} particles, the stored run has {traj.n_particles}")
        if k:
            displace(sy, a.perturb, k)  # as dcdc evaluate --members displaces its member k
        sim = Simulator(sy, SPHConfig.from_dict(scene.solver))
        t0, f = time.perf_counter(), 0
        for target in frames:
            while f < target:
                sim.advance(traj.frame_dt)
                f += 1
            act = traj.active(f)
            pred, true, com = compare_states(sy.x, traj.position[f], traj, act)
            line = {"trajectory": a.trajectory, "member": k, "perturb_m": a.perturb if k else 0.0,
                    "t": round(f * traj.frame_dt, 6), "com_height_error": float(np.nanmax(com)),
                    "order_ok": bool(pred["order_ok"]), "order_ok_true": bool(true["order_ok"]),
                    "wall_s": round(time.perf_counter() - t0, 1)}
            print(json.dumps(line), flush=True)
            if a.json:
                with open(a.json, "a") as fh:
                    fh.write(json.dumps(line) + "\n")


if __name__ == "__main__":
    main()
