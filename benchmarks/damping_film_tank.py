"""How much of the open scenes' stabilisation do the thin film and the tank at rest need?
The XSPH filter ε and the artificial viscosity ν (``xsph``, ``viscosity``; defaults 0.1 and
1e-3 m²/s) against three rows of ``dcdc validate-sph --dim 2`` (full): the thin film's
deep / shallow rise ratio (asks 0.67-1.5), the tank at rest's mean speed / √(gH) after 3 s
(asks < 1 % for the mean) — the film from the lattice start and two starts perturbed by
0.1 mm (``thin_film_starts.perturbed_tanks``), the tank from the case's own three starts
(at rest and two 1 mm/s random ones, ``cases.jitter``) — and the dam break's front speed
(lattice start; asks 1.251 ± 10 %). docs/sph.md, "What holds the thin film: the XSPH filter".

    python benchmarks/damping_film_tank.py 0.1/1e-3 0.05/1e-3 ... >> benchmarks/results/damping_film_tank.jsonl
    python benchmarks/damping_film_tank.py '{"reference_share": 1.0}' >> ...   # other settings
"""
from __future__ import annotations

import json
import sys
import time

from thin_film_starts import perturbed_tanks

from dcdc.sph import SPHConfig, cases

STARTS = (0, 1, 2)


def measure(overrides: dict) -> dict:
    cfg = SPHConfig.from_dict({**SPHConfig().to_dict(), **overrides})
    t = time.time()
    ratio, deep, shallow = [], [], []
    for start in STARTS:
        with perturbed_tanks(start):
            film = cases.film_pair(2, 0.005, cfg)
        ratio.append(round(film["ratio"], 3))
        deep.append(round(1e3 * film["deep"]["rise"], 1))
        shallow.append(round(1e3 * film["shallow"]["rise"], 1))
    # the rows by role, not by label: the checked speed row is the mean over the starts,
    # the information row beside it the largest start; the dam break checks only its speed
    speeds = [r for r in cases.hydrostatic(2, False, cfg) if r.quantity.startswith("mean speed")]
    mean = next(r.measured for r in speeds if r.passed is not None)
    largest = next(r.measured for r in speeds if r.passed is None)
    front = next(r.measured for r in cases.dam_break(2, False, cfg) if r.passed is not None)
    return {**overrides, "film_ratio": ratio, "film_deep_mm": deep,
            "film_shallow_mm": shallow,
            "tank_speed_mean": round(mean, 4), "tank_speed_largest": round(largest, 4),
            "dam_break_front_speed": round(front, 3),
            "wall_s": round(time.time() - t, 1)}


def main(argv: list[str]) -> None:
    for spec in argv or ["0.1/1e-3"]:
        if spec.startswith("{"):  # any other settings, as JSON
            overrides = json.loads(spec)
        else:
            xsph, viscosity = (float(v) for v in spec.split("/"))
            overrides = {"xsph": xsph, "viscosity": viscosity}
        print(json.dumps(measure(overrides)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
