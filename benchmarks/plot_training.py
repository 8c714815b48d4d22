"""Learning curves of training runs (metrics.csv of `dcdc train`) in one figure:
    python benchmarks/plot_training.py OUT.png LABEL=RUN1.csv[+RUN2.csv] ...
Runs joined with + are consecutive stages of one model (a fine-tune after its first run):
their steps are placed end to end. Training loss: a running mean over 200 steps (its value
depends on the stage's data and noise); validation loss: the fixed windows of the
validation split, without noise, comparable across stages."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    step = np.array([int(r["step"]) for r in rows])
    loss = np.array([float(r["loss"]) for r in rows])
    val = [(int(r["step"]), float(r["val_loss"])) for r in rows if r["val_loss"]]
    return step, loss, val


def main(out, specs):
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    for spec in specs:
        label, paths = spec.split("=", 1)
        offset, xs, ys, vx, vy, bounds = 0, [], [], [], [], []
        for p in paths.split("+"):
            step, loss, val = read(p)
            k = min(200, len(loss))
            xs.append(step[k - 1:] + offset)
            ys.append(np.convolve(loss, np.ones(k) / k, mode="valid"))
            vx += [s + offset for s, _ in val]
            vy += [v for _, v in val]
            offset += int(step.max())
            bounds.append(offset)
        line, = a.plot(np.concatenate(xs), np.concatenate(ys), lw=1, label=label)
        b.plot(vx, vy, "o-", ms=3, color=line.get_color(), label=label)
        for x in bounds[:-1]:
            for ax in (a, b):
                ax.axvline(x, color="0.7", lw=0.8, ls="--")
    a.set(xlabel="step", ylabel="training loss (mean of 200 steps)", title="training")
    b.set(xlabel="step", ylabel="validation loss", title="validation (64 fixed windows)")
    for ax in (a, b):
        ax.legend()
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
