"""The accuracy-speed frontier of the 3-D networks (issue 10; docs/model.md): validation
error of `dcdc evaluate` against ms per neural step of `dcdc benchmark model`, one point per
network configuration:
    python benchmarks/plot_frontier.py OUT.png LABEL=TIMING.json:ROW@EVAL.json:MODEL ...
TIMING.json is a `dcdc benchmark model --json` file and ROW the index of its row (the 10 k
particle row of the configuration); EVAL.json a `dcdc evaluate --json` file and MODEL the
label of the model in it. Two panels: two-step error (n+2, mm) and the per-phase
centre-of-mass height error at the end of the rollouts, both means over the validation
trajectories. Prints the points as a table."""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def point(spec):
    label, rest = spec.split("=", 1)
    timing, evaluation = rest.split("@")
    tpath, row = timing.rsplit(":", 1)
    epath, model = evaluation.rsplit(":", 1)
    t = json.load(open(tpath))["rows"][int(row)]
    e = json.load(open(epath))["aggregate"][model]
    return {"label": label, "ms": t["ms_per_step"], "particles": t["particles"],
            "neighbours": t.get("neighbours_mean"), "n2": e["err_n2_mm"],
            "com": e["com_height_error"], "rollout": e["rollout_mm"],
            "stable": f"{e['stable']}/{e['trajectories']}"}


def main(out, specs):
    pts = [point(s) for s in specs]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, name in ((axes[0], "n2", "n+2 position error [mm]"),
                          (axes[1], "com", "centre-of-mass height error")):
        for p in pts:
            ax.plot(p["ms"], p[key], "o")
            ax.annotate(p["label"], (p["ms"], p[key]), textcoords="offset points",
                        xytext=(5, 5), fontsize=8)
        ax.axvline(25, color="grey", ls="--", lw=0.8)
        ax.set_xlabel(f"ms per neural step, {pts[0]['particles']} particles, 2 cores")
        ax.set_ylabel(name)
        ax.set_xlim(0, 1.5 * max(p["ms"] for p in pts))
        ax.set_ylim(0, 1.2 * max(p[key] for p in pts))
    fig.suptitle("3-D validation (16 scenes, with wall contact) against the cost of a step; "
                 "dashed: the 25 ms target")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("| network | ms/step | neighbours | n+2 mm | rollout mm | COM err | stable |")
    print("|---|---|---|---|---|---|---|")
    for p in pts:
        nb = "-" if p["neighbours"] is None else f"{p['neighbours']:.1f}"
        print(f"| {p['label']} | {p['ms']:.0f} | {nb} | {p['n2']:.2f} | {p['rollout']:.1f} | "
              f"{p['com']:.3f} | {p['stable']} |")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
