"""Compare two SPH datasets of the same scenes made with different solver settings (e.g. the
random training scenes with the defaults and with ``--sph reference_surface=true``):

    python benchmarks/compare_sph_sets.py A_DIR B_DIR [--json OUT]

Per set, over the trajectories both hold (same names): how many exist and how many diverged
(recorded as NAME.failed.json), and, at the last frame, medians over the scenes of the
particle-scale motion (the mean over particles of |v_i - the mean velocity of the fluid
within 4 r|, the jitter a learned model cannot predict; docs/sph.md, "What the stabilisation
is for"), the mean speed, the 99th-percentile and largest speed, the layer purity
(:func:`dcdc.metrics.neighbour_purity_per_phase`, mean over phases) and the share of scenes
whose phases end in density order.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from dcdc import metrics
from dcdc.data.dataset import Dataset
from dcdc.neighbors import radius_search


def last_frame_stats(traj) -> dict:
    last = traj.n_frames - 1
    sy = traj.system(last)
    act = traj.active(last)
    x, v, phase = sy.x[act], sy.v[act], sy.phase[act]
    dens = np.array([p.density for p in sy.phases])
    r = float(sy.radius)
    nb = radius_search(x, 4.0 * r)  # self included: no row is empty
    vmean = np.add.reduceat(v[nb.index], nb.row_splits[:-1], axis=0) / nb.counts[:, None]
    speed = np.sqrt((v ** 2).sum(1))
    purity = metrics.neighbour_purity_per_phase(x, phase, 2.5 * r, len(dens))
    return {"particle_scale": float(np.sqrt(((v - vmean) ** 2).sum(1)).mean()),
            "mean_speed": float(speed.mean()), "p99_speed": float(np.percentile(speed, 99)),
            "max_speed": float(speed.max()), "purity": float(np.nanmean(purity)),
            "order": bool(metrics.density_order_ok(x, phase, dens))}


def summarise(path: Path, names: list[str]) -> dict:
    ds = Dataset(path)
    have = set(ds.names)
    rows = {n: last_frame_stats(ds[n]) for n in names if n in have}
    failed = [n for n in names if (path / f"{n}.failed.json").exists()]
    med = lambda k: float(np.median([r[k] for r in rows.values()]))  # noqa: E731
    return {"trajectories": len(rows), "diverged": len(failed),
            **{k: med(k) for k in ("particle_scale", "mean_speed", "p99_speed", "max_speed", "purity")},
            "order_ok": float(np.mean([r["order"] for r in rows.values()])), "per_trajectory": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    pa, pb = Path(a.a), Path(a.b)
    names = sorted({p.stem.removesuffix(".failed") for d in (pa, pb) for p in d.glob("*.h5")}
                   | {p.name.removesuffix(".failed.json") for d in (pa, pb) for p in d.glob("*.failed.json")})
    out = {str(p): summarise(p, names) for p in (pa, pb)}
    print(f"{'set':<40} {'n':>3} {'div':>4} {'jitter':>7} {'|v|':>6} {'p99':>6} {'max':>6} {'purity':>7} {'order':>6}")
    for p, s in out.items():
        print(f"{p:<40} {s['trajectories']:>3} {s['diverged']:>4} {s['particle_scale']:>7.3f} "
              f"{s['mean_speed']:>6.3f} {s['p99_speed']:>6.2f} {s['max_speed']:>6.2f} {s['purity']:>7.3f} "
              f"{s['order_ok']:>6.2f}")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
