"""The 3-D start-up burst, measured (docs/models.md, "The cocktail's start-up burst").

    python benchmarks/startup_burst.py [--steps 60] [--json F] MODEL [MODEL ...]

Each model runs the built-in 3-D cocktail and Rayleigh–Taylor tank from their lattice
starts (as `dcdc simulate --scene S`, wall contact on, default guard) for ``--steps`` steps
of 0.02 s. Reported per model and scene: the peak over steps of the 99th-percentile particle
speed [m/s] and its step, the steps run (the guard's verdict when it stopped early) and, for
the cocktail, the particles that left the glass (below its stem top, y < 0.3 m, i.e. on the
table) at the last step. The SPH rows: the scene's own solver over the same span.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

SCENES = ["cocktail", "rayleigh_taylor"]
STEM_TOP = 0.3  # the cocktail glass's bowl bottom: fluid below it has left the glass


def p99(v: np.ndarray) -> float:
    return float(np.percentile(np.linalg.norm(v, axis=-1), 99))


def summary(name: str, speeds: list[float], y_end, steps: int, stopped) -> dict:
    k = int(np.argmax(speeds))
    row = {"model": name, "peak_p99_speed": float(speeds[k]), "peak_step": k,
           "steps": steps, "stopped": "" if stopped is None else str(stopped)}
    if y_end is not None:
        row["left_glass"] = int((y_end < STEM_TOP).sum())
    return row


def run_model(path: str, scene: str, steps: int) -> dict:
    from dcdc.evaluate.start import start_from_scene
    from dcdc.evaluate.rollout import Guard, NeuralSimulator, run
    from dcdc.model.checkpoint import load_checkpoint

    model, _ = load_checkpoint(path)
    system, _, _ = start_from_scene(scene, 3, 1.0, model, steps, None)
    ro = run(NeuralSimulator(model, system, guard=Guard(), contact=True), steps)
    y_end = ro.position[-1][:, 1] if scene == "cocktail" else None
    return summary(path, [p99(v) for v in ro.velocity], y_end, ro.steps, ro.stopped)


def sph_reference(scene: str, steps: int) -> dict:
    """The scene's own SPH solver over the same span, frames of 0.02 s."""
    from dcdc.evaluate.start import settle_with_sph
    from dcdc.scene import get_scene

    system = get_scene(scene).realize(dim=3)
    speeds = [p99(system.v)]
    settle_with_sph(system, scene, steps, 0.02, progress=lambda _: speeds.append(p99(system.v)))
    return summary("SPH (reference)", speeds, system.x[:, 1] if scene == "cocktail" else None,
                   steps, None)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+")
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    rows = {s: [sph_reference(s, a.steps)] for s in SCENES}
    for m in a.models:
        for s in SCENES:
            rows[s].append(run_model(m, s, a.steps))
    for s in SCENES:
        print(f"\n{s} (3-D, lattice start, {a.steps} steps)")
        print(f"{'model':<44}{'peak p99 m/s':>13}{'at step':>8}{'steps':>7}{'left glass':>11}")
        for r in rows[s]:
            print(f"{r['model']:<44}{r['peak_p99_speed']:>13.2f}{r['peak_step']:>8}"
                  f"{r['steps']:>7}{r.get('left_glass', ''):>11}")
    if a.json:
        Path(a.json).write_text(json.dumps({"steps": a.steps, "scenes": rows}, indent=1))
        print(f"wrote {a.json}")


if __name__ == "__main__":
    main()
