"""Write 3-D scene files of deep layered columns resting in a tank (docs/models.md, "The
cocktail's start-up burst"): the situation the random training scenes lack.

    python benchmarks/make_deep_columns.py OUT_DIR [N=12] [SEED=0]

Each scene: a closed box tank (footprint 0.5-0.8 m, so 2 000-4 500 particles at r = 2.5 cm),
a column 0.8-1.5 m deep, every face on the lattice so that it starts with no gaps,
of 2-4 layers resting on the floor from its lattice start, densities
drawn log-uniformly from 500-5000 kg/m³ with a ratio of at most 10 (the training range) in a
random order (so most columns are unstable somewhere), half of them moving sideways at up
to 0.6 m/s at t = 0. Then `dcdc generate --dim 3 OUT_DIR/*.toml --split train -o DATA`.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

COLORS = ["#3a78d8", "#f2c230", "#f07a1a", "#c0182a"]
SPACING = 0.05  # 2r at the 3-D default radius 2.5 cm


def on_lattice(v: float) -> float:
    """``v`` rounded to a multiple of the particle spacing."""
    return round(SPACING * round(float(v) / SPACING), 2)


def scene(seed: int) -> str:
    rng = np.random.default_rng([7, seed])
    # every face on a lattice face plane (multiples of the spacing 2r = 5 cm): box blocks
    # then tile the tank with no empty row between layers or beside the walls (a face
    # between planes leaves one, and the column starts by falling into it)
    wx, wz = (on_lattice(v) for v in rng.uniform(0.5, 0.8, size=2))
    depth = float(rng.uniform(0.8, 1.5))
    n = int(rng.integers(2, 5))
    total = int(round(depth / SPACING))
    rows = 3 + rng.multinomial(total - 3 * n, rng.dirichlet(np.ones(n)))
    tops = np.round(SPACING * np.cumsum(rows), 2)  # every layer >= 3 rows (0.15 m)
    depth = float(tops[-1])
    bottoms = np.append(0.0, tops[:-1])
    while True:
        rho = np.round(np.exp(rng.uniform(np.log(500), np.log(5000), size=n)), -1)
        if rho.max() / rho.min() <= 10 and len(set(rho)) == n:
            break
    vx = round(float(rng.uniform(-0.6, 0.6)), 2) if rng.random() < 0.5 else 0.0
    height = round(depth + 0.4, 2)
    lines = [f'name = "deep_column_{seed}"',
             f'description = "{n} layers, {depth:.2f} m deep, resting in a box tank"',
             "dim = 3", "duration = 2.6", f"seed = {seed}", "",
             "[domain]", f"min = [0.0, 0.0, 0.0]", f"max = [{wx}, {height}, {wz}]", ""]
    for k in range(n):
        lines += [f"[phases.p{k}]", f"density = {rho[k]:g}", "viscosity = 1e-6",
                  f'color = "{COLORS[k]}"', ""]
    lines += ["[walls.tank]", 'shape = "box"', "min = [0.0, 0.0, 0.0]",
              f"max = [{wx}, {height}, {wz}]", "hollow = true", "open_top = false", ""]
    for k in range(n):
        lines += ["[[fluid]]", f'phase = "p{k}"', 'shape = "box"',
                  f"min = [0.0, {bottoms[k]:.2f}, 0.0]", f"max = [{wx}, {tops[k]:.2f}, {wz}]",
                  f"velocity = [{vx}, 0.0, 0.0]", ""]
    return "\n".join(lines)


def main(argv: list[str]) -> None:
    out = Path(argv[0])
    n = int(argv[1]) if len(argv) > 1 else 12
    seed0 = int(argv[2]) if len(argv) > 2 else 0
    out.mkdir(parents=True, exist_ok=True)
    for s in range(seed0, seed0 + n):
        (out / f"deep_column_{s}.toml").write_text(scene(s))
    print(f"wrote {n} scenes to {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
