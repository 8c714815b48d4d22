"""Is the 2-D thin-film ratio's change between sessions 20 and 21 (0.47 -> 0.39) noise? The
full 2-D `thin_film` row (r = 5 mm, defaults) from its lattice start and from starts
perturbed by 0.1 mm (Gaussian, seeds 1, 2, ...): rise under 0.3 m and under 0.12 m of 2:1
heavier fluid after 1 s, and their ratio (docs/sph.md, "Why light fluid stays under heavy
fluid"; the row asks 0.67-1.5).

    python benchmarks/thin_film_starts.py 0 1 2 >> benchmarks/results/thin_film_starts.jsonl
    python benchmarks/thin_film_starts.py --r 0.0075 0 1 2 3 4 5 >> benchmarks/results/thin_film_starts.jsonl

``--r`` sets the particle radius (default 5 mm, the 2-D row's, quick and full: the film two
rows thick; 7.5 mm makes it 1⅓ rows, 10 mm one). Records without ``r`` are at 5 mm.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time

import numpy as np

from dcdc.sph import SPHConfig, cases

PERTURBATION = 1e-4  # [m]


@contextlib.contextmanager
def perturbed_tanks(start: int):
    """Within it, every tank the validation cases build (``cases.tank_system``) has its
    particles moved by ``PERTURBATION`` (Gaussian, seed ``start``; 0: the lattice as is)."""
    tank = cases.tank_system
    rng = np.random.default_rng(start)

    def perturbed(*args, **kwargs):
        sy = tank(*args, **kwargs)
        if start:
            sy.x += rng.normal(0.0, PERTURBATION, sy.x.shape)
        return sy
    cases.tank_system = perturbed
    try:
        yield
    finally:
        cases.tank_system = tank


def main(argv: list[str]) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--r", type=float, default=0.005, help="particle radius [m]")
    ap.add_argument("starts", type=int, nargs="*", default=[0])
    args = ap.parse_args(argv)
    for start in args.starts:
        t = time.time()
        with perturbed_tanks(start):
            runs = cases.film_pair(2, args.r, SPHConfig())
        print(json.dumps({"r": args.r, "start": start, "ratio": round(runs["ratio"], 3),
                          "rise_deep_mm": round(1e3 * runs["deep"]["rise"], 1),
                          "rise_shallow_mm": round(1e3 * runs["shallow"]["rise"], 1),
                          "left_deep": round(runs["deep"]["left"], 3),
                          "left_shallow": round(runs["shallow"]["left"], 3),
                          "wall_s": round(time.time() - t, 1)}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
