"""The suite's measures against training windows, from the JSON files of `dcdc suite score`:
    python benchmarks/plot_suite_curve.py OUT.png ALONE.json[,...] CONTACT.json[,...] LABEL=WINDOWS ...
Two panels: the networks alone (the first list of files) and with the walls' contact (the
second). LABEL is a model label of the files (`dcdc suite score` labels a checkpoint by its
file name, `model`, `model#1`, ... for several model.pt), WINDOWS the training windows it saw
(steps × scenes per batch). The SPH floor is drawn dotted; the plotted values are printed."""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MEASURES = [("stable", "runs to the end"), ("com_within_5pct", "COM within 5 %"),
            ("layers_ok", "layers like SPH"), ("purity_ratio_median", "purity / SPH")]
FLOOR = "SPH floor"


def rows_of(paths):
    rows = {}
    for p in paths:
        for r in json.load(open(p))["rows"]:
            if r["group"] == "all":
                rows[r["model"]] = r
    return rows


def value(row, key):
    """The measure; NaN (not drawn) for a purity median without a run to the end."""
    v = row["stable"] / row["runs"] if key == "stable" else row[key]
    return float("nan") if v is None else v


def panel(ax, rows, specs, title):
    pts = []
    for label, windows in specs:
        if label not in rows:
            sys.exit(f"error: no model {label!r} in the {title} files (models: {', '.join(rows)})")
        pts.append((windows, label, rows[label]))
    pts.sort()
    print(title)
    print(f"  {'model':<10} {'windows':>8} " + " ".join(f"{name:>16}" for _, name in MEASURES))
    for w, label, r in pts:
        print(f"  {label:<10} {w:>8} " + " ".join(f"{value(r, k):>16.3f}" for k, _ in MEASURES))
    for (key, name), color in zip(MEASURES, ["C0", "C1", "C2", "C3"]):
        ax.plot([w for w, _, _ in pts], [value(r, key) for _, _, r in pts], "o-", color=color,
                label=name)
        if FLOOR in rows:
            ax.axhline(value(rows[FLOOR], key), color=color, ls=":", lw=1)
    ax.set_xscale("log")
    ax.set_xlabel("training windows")
    ax.set_ylim(0, 1.02)
    ax.set_title(title, fontsize=9)


def main(out, alone, contact, specs):
    specs = [(s.rsplit("=", 1)[0], int(s.rsplit("=", 1)[1])) for s in specs]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    panel(axes[0], rows_of(alone), specs, "the network alone")
    panel(axes[1], rows_of(contact), specs, "with the walls' contact")
    axes[0].set_ylabel("fraction of the 40 scenes (purity: median ratio)")
    axes[1].legend(fontsize=8, loc="lower right")
    fig.suptitle("2-D suite against training budget (dotted: SPH floor)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2].split(","), sys.argv[3].split(","), sys.argv[4:])
