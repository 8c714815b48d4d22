"""Markdown tables of `dcdc evaluate` JSON files for docs/models.md:
    python benchmarks/eval_tables.py benchmarks/eval_2d_*.json
One table per file (a row per model: means over its trajectories), then for files of
built-in scenes one row per scene (steps, final order, centre-of-mass error)."""
import json
import sys
from collections import Counter
from pathlib import Path


def fmt(v, f="{:.2f}"):
    return "-" if v is None else f.format(v)


def summary(path):
    doc = json.loads(Path(path).read_text())
    trajs = doc["trajectories"]
    n = len(trajs)
    contact = "with" if doc.get("contact", True) else "without"
    out = [f"**{Path(path).stem}** ({doc['data']}, {n} trajectories, wall contact {contact})", "",
           "| model | n+1 mm | n+2 mm | rollout mm | Sinkhorn mm | KE err | COM err | order ok "
           "| stable | steps (mean / requested) | stop causes | in walls (max) | contacts/step | ms/step |",
           "|" + "---|" * 14]
    for label, agg in doc["aggregate"].items():
        rows = [t[label] for t in trajs.values()]
        causes = Counter(r["stop_cause"] for r in rows if r["stop_cause"])
        steps = sum(r["steps"] for r in rows) / n
        req = sum(r["steps_requested"] for r in rows) / n
        out.append(
            f"| {label} | {fmt(agg['err_n1_mm'])} | {fmt(agg['err_n2_mm'])} | "
            f"{fmt(agg['rollout_mm'], '{:.1f}')} | {fmt(agg['sinkhorn_mm'], '{:.0f}')} | "
            f"{fmt(agg['ke_error'])} | {fmt(agg['com_height_error'], '{:.3f}')} | "
            f"{fmt(agg['order_ok'])} | {agg['stable']}/{n} | {steps:.0f} / {req:.0f} | "
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
    return "\n".join(out)


if __name__ == "__main__":
    print("\n".join(summary(p) for p in sys.argv[1:]))
