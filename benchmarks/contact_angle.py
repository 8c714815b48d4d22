"""Young's contact angle of a drop on a wall with the "pairwise" tension's wall tensions
(``sph.wall_tension``; docs/sph.md, "Wetting"): a half disc (hemisphere) of radius R
(2-D: 8 spacings, 3-D: 4) on the floor of a closed box, equal densities, no gravity, starting at 90°
(:func:`dcdc.sph.experiments.sessile_drop_run`), its angle every 0.25 s
(:func:`dcdc.sph.measures.cap_contact_angle`):

    python benchmarks/contact_angle.py --dim 2 60 90 120 150 >> benchmarks/results/contact_angle.jsonl
    python benchmarks/contact_angle.py --dim 2 --closed 60 90 120 150 >> benchmarks/results/contact_angle.jsonl
    python benchmarks/contact_angle.py --dim 3 90 120 >> benchmarks/results/contact_angle.jsonl
    python benchmarks/contact_angle.py --dim 3 120 --duration 8 >> benchmarks/results/contact_angle.jsonl
    python benchmarks/contact_angle.py --dim 2 --start 150 90 120 >> benchmarks/results/contact_angle.jsonl
    python benchmarks/contact_angle.py --dim 3 --start 150 120 >> benchmarks/results/contact_angle.jsonl

``--start``: the cap's angle at the start (default 90°, a half disc / hemisphere); from 150°
the drops show how far the contact line can advance (hysteresis).

``--closed``: the closed containers' damping (a tenth of the default XSPH and artificial
viscosity, :data:`dcdc.sph.reference.CLOSED_DAMPING`) instead of the defaults. 2-D: r = 5 mm,
R = 8 cm (1 250 particles); 3-D: r = 12.5 mm, R = 10 cm. One JSON line per angle.
"""
from __future__ import annotations

import argparse
import json

from dcdc.sph.experiments import sessile_drop_run
from dcdc.sph.reference import CLOSED_DAMPING


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("angles", nargs="+", type=float, help="Young's angles [degrees, through the drop]")
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2)
    ap.add_argument("--closed", action="store_true", help="the closed containers' damping")
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--start", type=float, default=90.0,
                    help="the cap's angle at the start [degrees] (90: a half disc / hemisphere)")
    a = ap.parse_args(argv)
    r, R = (0.005, 0.08) if a.dim == 2 else (0.0125, 0.1)
    settings = dict(CLOSED_DAMPING) if a.closed else {}
    for theta in a.angles:
        m = sessile_drop_run(a.dim, theta, r=r, R=R, duration=a.duration, settings=settings,
                             start=a.start)
        print(json.dumps({"dim": a.dim, "young": theta, "start": a.start,
                          "damping": "closed" if a.closed else "default",
                          "r": r, "R": R, "particles": m["n"], "every_s": 0.25,
                          "theta": [round(t, 1) for t in m["theta"]],
                          "final": round(m["theta"][-1], 1), "wall_s": round(m["wall"], 1)}),
              flush=True)


if __name__ == "__main__":
    main()
