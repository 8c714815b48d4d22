"""Markdown tables of `dcdc evaluate` JSON files for docs/models.md:
    python benchmarks/eval_tables.py benchmarks/results/eval_2d_*.json
One table per file (a row per model: means over its trajectories), then for files of
built-in scenes one row per scene (steps, final order, centre-of-mass error), and where a
file holds dcdc2d and cconv2d (or dcdc3d and cconv3d, or dcdcX_sK and cconvX_sK of one
training seed) a paired comparison: per metric, on how many trajectories
dcdc2d is better, and the mean difference with a 95 % bootstrap interval over trajectories
(the spread between scenes; the spread between training seeds is not in it)."""
import json
import sys

import numpy as np
from collections import Counter
from pathlib import Path


def fmt(v, f="{:.2f}"):
    return "-" if v is None else f.format(v)


def summary(path):
    doc = json.loads(Path(path).read_text())
    trajs = doc["trajectories"]
    n = len(trajs)
    used = doc.get("contact", True)  # one flag, or {model: flag} (each model's own default)
    used = set(used.values()) if isinstance(used, dict) else {used}
    contact = {frozenset({True}): "with", frozenset({False}): "without"}.get(
        frozenset(used), "each model's default")
    out = [f"**{Path(path).stem}** ({doc['data']}, {n} trajectories, wall contact {contact})", "",
           "| model | n+1 mm | n+2 mm | rollout mm | W2 mm | KE err | COM err | order ok "
           "| layers like SPH | stable | steps (mean / requested) | stop causes | in walls (max) | contacts/step | ms/step |",
           "|" + "---|" * 15]
    for label, agg in doc["aggregate"].items():
        rows = [t[label] for t in trajs.values()]
        causes = Counter(r["stop_cause"] for r in rows if r["stop_cause"])
        steps = sum(r["steps"] for r in rows) / n
        req = sum(r["steps_requested"] for r in rows) / n
        out.append(
            f"| {label} | {fmt(agg['err_n1_mm'])} | {fmt(agg['err_n2_mm'])} | "
            f"{fmt(agg['rollout_mm'], '{:.1f}')} | {fmt(agg.get('w2_mm'), '{:.0f}')} | "
            f"{fmt(agg['ke_error'])} | {fmt(agg['com_height_error'], '{:.3f}')} | "
            f"{fmt(agg['order_ok'])} | {fmt(agg.get('layers_ok'))} | {agg['stable']}/{n} | {steps:.0f} / {req:.0f} | "
            f"{', '.join(f'{k} {v}' for k, v in sorted(causes.items())) or '-'} | "
            f"{max(r['in_walls_max'] for r in rows)} | "
            f"{fmt(agg.get('contacts_per_step'), '{:.1f}')} | {fmt(agg['ms_per_step'], '{:.1f}')} |")
    truth = sum(next(iter(t.values()))["order_ok_true"] for t in trajs.values())
    out += ["", f"SPH truth order ok: {truth}/{n}", ""]
    if all(not k.startswith("random_") for k in trajs):
        labels = list(doc["aggregate"])
        out += ["| scene | " + " | ".join(f"{m}: steps, order, COM err" for m in labels)
                + " | SPH order |", "|" + "---|" * (len(labels) + 2)]
        for name, per in trajs.items():
            cells = []
            for m in labels:
                r = per[m]
                st = f"{r['steps']}" + (f" ({r['stop_cause']})" if r["stop_cause"] else "")
                cells.append(f"{st}, {'yes' if r['order_ok'] else 'no'}, "
                             f"{fmt(r['com_height_error'], '{:.3f}')}")
            sph = "yes" if next(iter(per.values()))["order_ok_true"] else "no"
            out.append(f"| {name} | " + " | ".join(cells) + f" | {sph} |")
        out.append("")
    for a in doc["aggregate"]:  # dcdc2d / cconv2d, and dcdc2d_s1 / cconv2d_s1 of a seed
        b = "cconv" + a[4:]
        if a.startswith("dcdc") and b in doc["aggregate"] and n > 1:
            out += paired(trajs, a, b)
    return "\n".join(out)


PAIRED = [("n+1 mm", "err_n1_mm"), ("n+2 mm", "err_n2_mm"), ("rollout mm", "rollout_mm"),
          ("W2 mm", "w2_mm"), ("COM err", "com_height_error"),
          ("height W1 / column", "height_w1_rel_max"), ("purity / SPH's, lowest phase (HIGHER is better)", "purity_ratio_min"),
          ("KE err", "ke_error")]


def paired(trajs, a, b, n_boot=10000):
    """Rows: metric, trajectories where a < b (of those both have), mean(a − b) [95 % CI]."""
    rng = np.random.default_rng(0)
    out = [f"Paired, {a} − {b} (lower is better for {a}):", "",
           "| metric | trajectories where " + a + " is lower | mean difference | 95 % interval |",
           "|---|---|---|---|"]
    for name, k in PAIRED:
        d = np.array([t[a][k] - t[b][k] for t in trajs.values()
                      if t[a].get(k) is not None and t[b].get(k) is not None])
        if not len(d):
            continue
        boot = rng.choice(d, (n_boot, len(d))).mean(1)
        lo, hi = np.percentile(boot, [2.5, 97.5])
        out.append(f"| {name} | {int((d < 0).sum())} / {len(d)} | {d.mean():+.4g} | "
                   f"[{lo:+.3g}, {hi:+.3g}] |")
    return out + [""]


if __name__ == "__main__":
    print("\n".join(summary(p) for p in sys.argv[1:]))
