"""What holds the 2-D cocktail's last oil at the glass (docs/sph.md, "The film one particle
thick"): the scene's defaults to 10 s, then 5 s more with one setting changed at a time,
from the same 10 s state; oil (and every phase's) share held at the glass under denser
fluid (:func:`dcdc.metrics.trapped_at_walls`) at 11-15 s.

    python benchmarks/cocktail_film_holders.py >> benchmarks/results/cocktail_film_holders.jsonl

Variants: the defaults; interfacial tension off; XSPH and artificial viscosity off; the
layered reference taking 0.97 and 1.0 of each slab's density (default 0.9); a balanced wall
(``wall_contact_support`` 2); the "csf" tension model; the density solve's tolerance
10× and 100× looser (the second with the divergence solve's at 1 %); particle shifting
after every substep, δx_i = −A h² ∇ψ_i on particles with ψ_i ≥ 0.98 (Lind et al. 2012, J.
Comput. Phys. 231, on the solver's own ψ; positions only, the probe of a fix), A = 0.01, 0.05.
"""
from __future__ import annotations

import copy
import functools
import json
import sys
import time

import numpy as np

import dcdc.sph.dfsph as dfsph
import dcdc.sph.solver as solver
from dcdc import metrics
from dcdc.scene import get_scene
from dcdc.sph import Simulator, SPHConfig
from dcdc.sph.reference import strata
from dcdc.sph.terms import psi_gradient

RESOLUTION = 2.0  # the demo's
VARIANTS = {  # name: (solver overrides, share of each slab's density in the reference, shift A)
    "defaults": ({}, None, 0.0),
    "no interfacial tension": ({"interfacial_tension": {}}, None, 0.0),
    "xsph 0, viscosity 0": ({"xsph": 0.0, "viscosity": 0.0}, None, 0.0),
    "reference share 0.97": ({}, 0.97, 0.0),
    "reference share 1.0": ({}, 1.0, 0.0),
    "wall_contact_support 2": ({"wall_contact_support": 2.0}, None, 0.0),
    "interfacial_model csf": ({"interfacial_model": "csf"}, None, 0.0),
    "density_tolerance 1e-3": ({"density_tolerance": 1e-3}, None, 0.0),
    "density_tolerance 1e-2, divergence_tolerance 1e-2": (
        {"density_tolerance": 1e-2, "divergence_tolerance": 1e-2}, None, 0.0),
    "shifting A 0.01": ({}, None, 0.01),
    "shifting A 0.05": ({}, None, 0.05),
}
SUBSTEP = dfsph.substep


def shifting(a: float):
    """dfsph.substep followed by the shift δx = −a h² ∇ψ on particles with ψ ≥ 0.98."""
    def substep(s, nbh, dt, cfg):
        info = SUBSTEP(s, nbh, dt, cfg)
        grad = psi_gradient(nbh.rs, nbh.G, nbh.Sb, s.V0)
        s.x -= a * s.h * s.h * grad * (nbh.psi >= 0.98)[:, None]
        return info
    return substep


def trapped(sy) -> list[float]:
    layers = metrics.layer_summary(sy.x, sy.phase, [p.density for p in sy.phases], sy.wall_x,
                                   sy.radius)
    return np.round(layers["trapped"], 4).tolist()


def main() -> None:
    solver.check_fluid_outside_walls = lambda *a, **k: None  # a restart from a stored state
    scene = get_scene("cocktail")
    sy = scene.realize(2, RESOLUTION)
    Simulator(sy, SPHConfig.from_dict(scene.solver)).run(10.0, 0.02)
    print(json.dumps({"variant": "state at 10 s", "phases": [p.name for p in sy.phases],
                      "trapped": trapped(sy)}), flush=True)
    for name, (overrides, share, shift) in VARIANTS.items():
        if len(sys.argv) > 1 and name not in sys.argv[1:]:
            continue
        solver.strata = strata if share is None else functools.partial(strata, share=share)
        dfsph.substep = shifting(shift) if shift > 0 else SUBSTEP
        s2 = copy.deepcopy(sy)
        sim = Simulator(s2, SPHConfig.from_dict({**scene.solver, **overrides}))
        t, out = time.time(), {}
        for k in range(11, 16):
            sim.run(1.0, 0.02)
            out[k] = trapped(s2)
        print(json.dumps({"variant": name, "trapped": out, "wall_s": round(time.time() - t, 1)}),
              flush=True)
    solver.strata, dfsph.substep = strata, SUBSTEP


if __name__ == "__main__":
    main()
