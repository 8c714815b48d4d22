"""Does the interfacial tension's pressure jump depend on the pressure level? (docs/sph.md,
"Interfacial tension"). The `laplace` case of `dcdc validate-sph`
(2-D quick: r = 1 cm, R = 9 cm, σ = 10 N/m, equal densities, closed 0.4 m box, 1.5 s;
:func:`dcdc.sph.fixtures.laplace_drop`) with
gravity g switched on: over the last 0.5 s, the drop's pressure within R/2 of its centre
minus a least-squares linear fit (in height) of the ambient's beyond R + h and h from the
walls; the same run with σ = 0 from the same start is subtracted ("diff"), which removes
the hydrostatic discretisation error the fit leaves. Young-Laplace: diff = 1.

    python benchmarks/laplace_pressure_level.py >> benchmarks/results/laplace_pressure_level.jsonl
"""
from __future__ import annotations

import json
import time

import numpy as np

from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.fixtures import laplace_box, laplace_drop
from dcdc.sph.measures import drop_radius, max_radius_ratio, run

NO_REFERENCE = {"reference_surface": False, "reference_stratified": False}
RUNS = [  # (model, g [m/s²], solver overrides)
    ("pairwise", 2.0, {}), ("pairwise", 9.81, {}), ("pairwise", 30.0, {}),
    ("pairwise", 9.81, NO_REFERENCE),
    ("csf", 9.81, {}), ("csf", 30.0, {}), ("csf", 9.81, NO_REFERENCE), ("csf", 30.0, NO_REFERENCE),
]
SIGMA, R_PARTICLE, T = 10.0, 0.01, 1.5


def jump(model: str, g: float, sigma: float, overrides: dict) -> tuple[float, float, float]:
    """(mean drop pressure above the ambient's linear fit [Pa], R [m], max radius / R)."""
    W = laplace_box(2)
    sy = laplace_drop(2, R_PARTICLE)
    sy.gravity[:] = [0.0, -g]
    settings = {"interfacial_model": model, **overrides}
    if sigma > 0:
        settings["interfacial_tension"] = {"ambient/drop": sigma}
    sim = Simulator(sy, SPHConfig.from_dict(settings))
    drop = sy.phase == 1
    R = drop_radius(int(drop.sum()), sim.V0, 2)
    samples = []

    def sample(s, frame):
        if s.time > T - 0.5 - 1e-9:
            x, p = s.system.x, s.pressure()
            dist = np.linalg.norm(x - x[drop].mean(0), axis=1)
            far = (~drop) & (dist > R + sim.h) & (np.minimum(x, W - x).min(1) > sim.h)
            fit = np.linalg.lstsq(np.c_[np.ones(far.sum()), x[far, 1]], p[far], rcond=None)[0]
            core = drop & (dist < 0.5 * R)
            samples.append(float((p[core] - fit[0] - fit[1] * x[core, 1]).mean()))
    run(sim, T, sample)
    return float(np.mean(samples)), R, max_radius_ratio(sy.x[drop], R_PARTICLE, R)


def main() -> None:
    for model, g, overrides in RUNS:
        t = time.time()
        d1, R, shape = jump(model, g, SIGMA, overrides)
        d0 = jump(model, g, 0.0, overrides)[0]
        ref = SIGMA / R
        print(json.dumps({"model": model, "g": g, "overrides": overrides,
                          "jump_over_laplace": round(d1 / ref, 3),
                          "jump_sigma0_over_laplace": round(d0 / ref, 3),
                          "diff_over_laplace": round((d1 - d0) / ref, 3),
                          "max_radius_over_R": round(shape, 3), "R": round(R, 4),
                          "wall_s": round(time.time() - t, 1)}), flush=True)


if __name__ == "__main__":
    main()
