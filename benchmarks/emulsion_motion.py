"""How the network moves particles relative to their neighbours, one step from the teacher's
states and over its own rollout, against the SPH teacher (the suite's emulsions and layered
tanks):

    python benchmarks/emulsion_motion.py --model dcdc2d --suite datasets/suite_2d \\
        box_emulsion_900001_2d box_emulsion_900033_2d glass_900028_2d [--json out.json]

* one step (from SPH frames 5, 15, ..., 95): the slope of the network's relative
  displacement (each particle's displacement minus its neighbours' mean within 4 r) against
  SPH's, least squares through 0 (1: the same relative motion; < 1: damped), and of each
  phase's mean vertical drift relative to the whole fluid's;
* rollout (the network alone from the stored start): the rms relative velocity ("jitter")
  and the mean speed at 0.2, 1, 2, 3 s and the end, network against SPH at the same frame.
"""
import argparse
import json

import numpy as np
import torch

from dcdc.data.dataset import Dataset
from dcdc.evaluate.rollout import NeuralSimulator, run
from dcdc.model.checkpoint import load_checkpoint
from dcdc.model.integrator import step
from dcdc.neighbors import radius_search


def relative(x, d, radius):
    """d_i minus the mean of d over x_i's neighbours within ``radius`` (itself included)."""
    nb = radius_search(x, radius, x)
    rec, idx = nb.receivers(), nb.index
    cnt = np.maximum(np.bincount(rec, minlength=len(x)), 1)[:, None]
    mean = np.stack([np.bincount(rec, d[idx, k], minlength=len(x)) for k in range(x.shape[1])], 1)
    return d - mean / cnt


def slope(pred, true):
    return float((pred * true).sum() / (true * true).sum())


def one_step(net, t, frames):
    rho = t.density.astype(np.float64)
    wx, wn, g = (torch.as_tensor(a) for a in (t.wall_x, t.wall_n, t.gravity))
    P, T, dp_phase, dt_phase = [], [], [], []
    for f in frames:
        x0, v0 = t.position[f].astype(np.float64), t.velocity[f].astype(np.float64)
        with torch.no_grad():
            x1, _ = step(net, x0, v0, rho, wx, wn, None, g)
        dp, dt = x1.double().numpy() - x0, t.position[f + 1] - x0
        P.append(relative(x0, dp, 4 * t.radius).ravel())
        T.append(relative(x0, dt, 4 * t.radius).ravel())
        for ph in np.unique(t.phase):
            s = t.phase == ph
            dp_phase.append(dp[s, -1].mean() - dp[:, -1].mean())
            dt_phase.append(dt[s, -1].mean() - dt[:, -1].mean())
    P, T = np.concatenate(P), np.concatenate(T)
    return {"relative_slope": slope(P, T), "relative_corr": float(np.corrcoef(P, T)[0, 1]),
            "relative_rms_mm": [1e3 * float(np.sqrt((T ** 2).mean())), 1e3 * float(np.sqrt((P ** 2).mean()))],
            "phase_drift_slope": slope(np.array(dp_phase), np.array(dt_phase))}


def rollout(net, t, times):
    ro = run(NeuralSimulator(net, t.system(0), time=float(t.time[0]), contact=False), t.n_frames - 1)
    rows = []
    for s in times:
        k = min(int(round(s / t.frame_dt)), ro.steps)
        jit = [1e3 * float(np.sqrt((relative(x, v, 4 * t.radius) ** 2).sum(1).mean()))
               for x, v in ((t.position[k], t.velocity[k]), (ro.position[k], ro.velocity[k]))]
        speed = [1e3 * float(np.linalg.norm(v, axis=1).mean()) for v in (t.velocity[k], ro.velocity[k])]
        rows.append({"t": k * t.frame_dt, "jitter_mm_s": jit, "speed_mm_s": speed})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="dcdc2d")
    ap.add_argument("--suite", default="datasets/suite_2d")
    ap.add_argument("--json", default=None)
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args()
    net = load_checkpoint(a.model)[0]
    ds = Dataset(f"{a.suite}/truth")
    out = {}
    for name in a.scenes:
        t = ds[name]
        res = {"one_step": one_step(net, t, range(5, min(100, t.n_frames - 1), 10)),
               "rollout": rollout(net, t, (0.2, 1.0, 2.0, 3.0, (t.n_frames - 1) * t.frame_dt))}
        out[name] = res
        o = res["one_step"]
        print(f"{name}: one step: relative-motion slope {o['relative_slope']:.2f} (corr "
              f"{o['relative_corr']:.2f}), phase-drift slope {o['phase_drift_slope']:.2f}")
        for r in res["rollout"]:
            print(f"  t = {r['t']:4.1f} s  jitter SPH {r['jitter_mm_s'][0]:6.1f}  network "
                  f"{r['jitter_mm_s'][1]:6.1f} mm/s   mean speed SPH {r['speed_mm_s'][0]:6.1f}  "
                  f"network {r['speed_mm_s'][1]:6.1f} mm/s")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"model": a.model, "scenes": out}, f, indent=1)
        print(f"wrote {a.json}")


if __name__ == "__main__":
    torch.set_num_threads(1)
    main()
