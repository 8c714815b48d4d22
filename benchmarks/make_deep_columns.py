"""Write 3-D scene files of deep layered columns resting in a tank (docs/models.md, "The
cocktail's start-up burst"): the situation the random training scenes lack.

    python benchmarks/make_deep_columns.py OUT_DIR [N=12] [SEED=0] [KIND=tank|glass|neck|lock]

tank: a closed box tank (footprint 0.5-0.8 m, so 2 000-4 500 particles at r = 2.5 cm),
a column 0.8-1.5 m deep, every face on the lattice so that it starts with no gaps,
of 2-4 layers resting on the floor from its lattice start, densities
drawn log-uniformly from 500-5000 kg/m³ with a ratio of at most 10 (the training range) in a
random order (so most columns are unstable somewhere), half of them moving sideways at up
to 0.6 m/s at t = 0. glass: the same kind of column (2-4 layers, 0.1 m or more each, the lowest 0.2 m) in a
stemmed glass of random size (rim radius 0.45-0.7 m) and slenderness, filled to 60-90 % of
its height: a curved bottom that a lattice start meets with voids, as the cocktail does
(the cocktail's own glass is not among them). neck: a closed box tank split by a horizontal
plate with one slot (0.1-0.3 m wide, anywhere along it), the chamber below full of a light
liquid and heavy liquid resting on the plate above (ratio 1.5-10): the exchange flow through
an aperture that the random scenes lack (the hourglass's curved chambers and its neck are not
among them). lock: two liquids side by side over the full depth of a closed box tank
(1-2 m long, gate at 30-70 % of it, ratio 1.1-10, heavy on either side): the gravity currents
of a lock exchange (none as long as the built-in one, >= 1.7 m, at its ratio, 1.3-1.7). Then `dcdc generate --dim 3 OUT_DIR/*.toml --split train -o DATA` (a 3-D scene
file also yields its 2-D section: `--dim 2`).
"""
from __future__ import annotations

import sys
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as a package
    import tomli as tomllib

import numpy as np

COLORS = ["#3a78d8", "#f2c230", "#f07a1a", "#c0182a"]
SPACING = 0.05  # 2r at the 3-D default radius 2.5 cm


def on_lattice(v: float) -> float:
    """``v`` rounded to a multiple of the particle spacing."""
    return round(SPACING * round(float(v) / SPACING), 2)


def densities(rng, n: int) -> np.ndarray:
    """``n`` distinct densities, log-uniform in 500-5000 kg/m³, ratio at most 10."""
    while True:
        rho = np.round(np.exp(rng.uniform(np.log(500), np.log(5000), size=n)), -1)
        if rho.max() / rho.min() <= 10 and len(set(rho)) == n:
            return rho


def header(name: str, what: str, seed: int, lo, hi, rho, duration: float = 2.6) -> list[str]:
    lines = [f'name = "{name}"', f'description = "{what}"', "dim = 3", f"duration = {duration}",
             f"seed = {seed}", "", "[domain]", f"min = {list(lo)}", f"max = {list(hi)}", ""]
    for k, r in enumerate(rho):
        lines += [f"[phases.p{k}]", f"density = {r:g}", "viscosity = 1e-6",
                  f'color = "{COLORS[k]}"', ""]
    return lines


def closed_tank(wx: float, height: float, wz: float) -> list[str]:
    """The closed box tank [0, wx] x [0, height] x [0, wz] as scene-file lines."""
    return ["[walls.tank]", 'shape = "box"', "min = [0.0, 0.0, 0.0]",
            f"max = [{wx}, {height}, {wz}]", "hollow = true", "open_top = false", ""]


def box_fluid(phase: str, lo, hi, wz: float) -> list[str]:
    """A box fluid block from (x, y) ``lo`` to ``hi`` across the tank's depth [0, wz]."""
    return ["[[fluid]]", f'phase = "{phase}"', 'shape = "box"', f"min = [{lo[0]}, {lo[1]}, 0.0]",
            f"max = [{hi[0]}, {hi[1]}, {wz}]", ""]


def tank(seed: int) -> str:
    """A column in a closed box tank."""
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
    rho = densities(rng, n)
    vx = round(float(rng.uniform(-0.6, 0.6)), 2) if rng.random() < 0.5 else 0.0
    height = round(depth + 0.4, 2)
    lines = header(f"deep_column_{seed}", f"{n} layers, {depth:.2f} m deep, resting in a box tank",
                   seed, [0.0, 0.0, 0.0], [wx, height, wz], rho)
    lines += closed_tank(wx, height, wz)
    for k in range(n):
        lines += ["[[fluid]]", f'phase = "p{k}"', 'shape = "box"',
                  f"min = [0.0, {bottoms[k]:.2f}, 0.0]", f"max = [{wx}, {tops[k]:.2f}, {wz}]",
                  f"velocity = [{vx}, 0.0, 0.0]", ""]
    return "\n".join(lines)


# the cocktail glass's bowl profile per unit rim radius: (radius, height above the bottom)
BOWL = np.array([[0.0, 0.0], [0.43, 0.048], [0.71, 0.20], [0.88, 0.45], [0.98, 0.86],
                 [1.0, 1.49]])


def glass(seed: int) -> str:
    """A column in a stemmed glass of random size and slenderness: a curved bottom that a
    lattice start meets with voids, as in the cocktail (not the cocktail's glass itself)."""
    rng = np.random.default_rng([8, seed])
    rim = float(rng.uniform(0.45, 0.7))
    tall = float(rng.uniform(1.2, 1.7))
    stem = round(float(rng.uniform(0.1, 0.3)), 2)
    bowl = np.round(BOWL * np.array([rim, rim * tall]), 3)
    depth = float(rng.uniform(0.6, 0.9)) * float(bowl[-1, 1])
    n = int(rng.integers(2, 5))
    # every layer >= 0.1 m, the lowest >= 0.2 m (the narrow rounded bottom holds few points)
    thick = 0.1 + (depth - 0.1 * n - 0.1) * rng.dirichlet(np.ones(n)) + np.eye(n)[0] * 0.1
    tops = stem + np.cumsum(thick)
    bottoms = np.append(stem - 0.05, tops[:-1])  # below the bowl bottom: fill it
    rho = densities(rng, n)
    vx = round(float(rng.uniform(-0.6, 0.6)), 2) if rng.random() < 0.5 else 0.0
    half = round(rim + 0.2, 2)
    height = round(stem + float(bowl[-1, 1]) + 0.3, 2)
    lo, hi = [-half, 0.0, -half], [half, height, half]
    lines = header(f"deep_glass_{seed}", f"{n} layers, {depth:.2f} m deep, in a glass",
                   seed, lo, hi, rho)
    lines += ["[walls.case]", 'shape = "box"', f"min = {lo}", f"max = {hi}", "hollow = true",
              "open_top = false", "", "[walls.glass]", 'shape = "glass"',
              "center = [0.0, 0.0, 0.0]", f"foot = {round(0.5 * rim, 2)}", f"stem = {stem}",
              f"bowl = {bowl.tolist()}", ""]
    for k in range(n):
        lines += ["[[fluid]]", f'phase = "p{k}"', 'shape = "fill"', 'inside = "glass"',
                  f"min = [{-half}, {bottoms[k]:.3f}, {-half}]",
                  f"max = [{half}, {tops[k]:.3f}, {half}]",
                  f"velocity = [{vx}, 0.0, 0.0]", ""]
    return "\n".join(lines)


def neck(seed: int) -> str:
    """Heavy liquid above light in a tank split by a plate with one slot (all on the lattice)."""
    rng = np.random.default_rng([9, seed])
    wx, wz = on_lattice(rng.uniform(0.6, 1.0)), on_lattice(rng.uniform(0.4, 0.6))
    below = on_lattice(rng.uniform(0.4, 0.8))           # the light chamber's height
    plate = on_lattice(rng.uniform(0.1, 0.2))           # the plate's thickness
    slot = on_lattice(rng.uniform(0.1, 0.3))            # the slot's width
    x0 = on_lattice(rng.uniform(0.1, wx - slot - 0.1))  # its left edge
    pt = round(below + plate, 2)
    top = on_lattice(pt + rng.uniform(0.3, 0.6))        # the heavy layer's surface
    height = round(top + 0.3, 2)
    while True:
        ratio = float(np.exp(rng.uniform(np.log(1.5), np.log(10))))
        light = float(np.round(np.exp(rng.uniform(np.log(500), np.log(5000 / ratio))), -1))
        rho = np.array([light, np.round(light * ratio, -1)])
        if rho[1] <= 5000 and rho[1] > rho[0]:
            break
    lines = header(f"deep_neck_{seed}", f"heavy over light through a {slot:.2f} m slot, "
                   f"ratio {rho[1] / rho[0]:.1f}", seed, [0.0, 0.0, 0.0], [wx, height, wz],
                   rho, duration=4.0)
    lines += closed_tank(wx, height, wz)
    for name, (a, b) in {"left": (0.0, x0), "right": (round(x0 + slot, 2), wx)}.items():
        if b > a:
            lines += [f"[walls.plate_{name}]", 'shape = "box"', f"min = [{a}, {below}, 0.0]",
                      f"max = [{b}, {pt}, {wz}]", ""]
    blocks = [("p0", [0.0, 0.0], [wx, below]), ("p0", [x0, below], [round(x0 + slot, 2), pt]),
              ("p1", [0.0, pt], [wx, top])]
    for phase, lo, hi in blocks:
        lines += box_fluid(phase, lo, hi, wz)
    return "\n".join(lines)


def lock(seed: int) -> str:
    """Two liquids side by side over the full depth of a closed tank (a lock exchange)."""
    rng = np.random.default_rng([10, seed])
    wx, wz = on_lattice(rng.uniform(1.0, 2.0)), on_lattice(rng.uniform(0.3, 0.5))
    depth = on_lattice(rng.uniform(0.3, 0.7))
    height = round(depth + on_lattice(rng.uniform(0.05, 0.2)), 2)  # a gap under the lid
    gate = on_lattice(rng.uniform(0.3, 0.7) * wx)
    while True:  # not the built-in lock exchange's configuration (2 m long, ratio 1.5)
        ratio = float(np.exp(rng.uniform(np.log(1.1), np.log(10))))
        if not (wx >= 1.7 and 1.3 <= ratio <= 1.7):
            break
    light = float(np.round(np.exp(rng.uniform(np.log(500), np.log(5000 / ratio))), -1))
    rho = np.array([light, max(light + 10, float(np.round(light * ratio, -1)))])
    left, right = ("p1", "p0") if rng.random() < 0.5 else ("p0", "p1")
    lines = header(f"deep_lock_{seed}", f"lock exchange, ratio {rho[1] / rho[0]:.2f}, "
                   f"{wx:.2f} m long, {depth:.2f} m deep", seed, [0.0, 0.0, 0.0],
                   [wx, height, wz], rho, duration=3.0)
    lines += closed_tank(wx, height, wz)
    for phase, a, b in ((left, 0.0, gate), (right, gate, wx)):
        lines += box_fluid(phase, [a, 0.0], [b, depth], wz)
    return "\n".join(lines)


KINDS = {"tank": tank, "glass": glass, "neck": neck, "lock": lock}


def main(argv: list[str]) -> None:
    out = Path(argv[0])
    n = int(argv[1]) if len(argv) > 1 else 12
    seed0 = int(argv[2]) if len(argv) > 2 else 0
    kind = argv[3] if len(argv) > 3 else "tank"
    if kind not in KINDS:
        sys.exit(f"error: KIND must be one of {', '.join(KINDS)} (got {kind!r})")
    out.mkdir(parents=True, exist_ok=True)
    for s in range(seed0, seed0 + n):
        text = KINDS[kind](s)
        (out / f"{tomllib.loads(text)['name']}.toml").write_text(text)
    print(f"wrote {n} {kind} scenes to {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
