"""Does a change that should not matter (bf16 GEMMs) move the suite's measures more than a
change that does not matter (the same fp32 network from starts displaced by 1 µm)?

    python benchmarks/suite_precision.py MODEL FP32.json MEMBER.json CANDIDATE.json [--json OUT]

The three files are `dcdc suite score` runs of MODEL on the same suite: as stored (fp32),
``--perturb 1e-6`` (fp32, a member of the network's ensemble) and the candidate (``--bf16``).
Per scene and measure the candidate's distance from fp32 is set against the member's; the
candidate is within the ensemble spread where, for every measure, its median distance over
the scenes is no larger than the member's and no suite fraction moves by more than the
member's moves (+ one scene)."""
import argparse
import json
import sys

import numpy as np

CONTINUOUS = [("com_height_error", "COM height error"), ("purity_ratio_min", "purity / SPH (min)"),
              ("height_w1_rel_max", "height W1 / depth (max)")]
FRACTIONS = [("stable", "runs to the end"), ("order_ok", "final order right"),
             ("com_within_5pct", "COM within 5 %"), ("layers_ok", "layers like SPH")]


def load(path, model):
    d = json.load(open(path))
    if model not in d["models"]:
        sys.exit(f"error: {path}: no model {model!r} (models: {', '.join(d['models'])})")
    row = next(r for r in d["rows"] if r["model"] == model and r["group"] == "all")
    per = {n: s["models"][model] for n, s in d["scenes"].items()}
    return row, per, d


def fractions(row):
    return {k: (row["stable"] / row["runs"] if k == "stable" else row[k]) for k, _ in FRACTIONS}


def distances(a, b, key):
    out = []
    for n in a:
        x, y = a[n].get(key), b.get(n, {}).get(key)
        if x is None or y is None or not (np.isfinite(x) and np.isfinite(y)):
            continue
        out.append(abs(float(x) - float(y)))
    return np.array(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model")
    ap.add_argument("fp32")
    ap.add_argument("member")
    ap.add_argument("candidate")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    (r0, p0, d0), (r1, p1, _), (r2, p2, d2) = (load(p, a.model) for p in (a.fp32, a.member, a.candidate))
    if set(p0) != set(p1) or set(p0) != set(p2):
        sys.exit("error: the three runs are not on the same scenes")
    n = len(p0)
    res = {"model": a.model, "scenes": n, "continuous": {}, "fractions": {}}
    ok = True
    print(f"{a.model} on {n} scenes: distance from the fp32 run (median / max over scenes)")
    print(f"{'measure':26s} {'member (1 µm)':>20s} {'candidate':>20s}  within")
    for key, label in CONTINUOUS:
        dm, dc = distances(p0, p1, key), distances(p0, p2, key)
        within = bool(np.median(dc) <= np.median(dm))
        ok &= within
        res["continuous"][key] = {"member_median": float(np.median(dm)), "member_max": float(dm.max()),
                                  "candidate_median": float(np.median(dc)),
                                  "candidate_max": float(dc.max()), "within": within}
        print(f"{label:26s} {np.median(dm):9.4f} / {dm.max():8.4f} {np.median(dc):9.4f} / "
              f"{dc.max():8.4f}  {'yes' if within else 'NO'}")
    f0, f1, f2 = fractions(r0), fractions(r1), fractions(r2)
    print(f"\n{'suite fraction':26s} {'fp32':>8s} {'member':>8s} {'candidate':>10s}  within")
    for key, label in FRACTIONS:
        within = bool(abs(f2[key] - f0[key]) <= abs(f1[key] - f0[key]) + 1.0 / n + 1e-9)
        ok &= within
        res["fractions"][key] = {"fp32": f0[key], "member": f1[key], "candidate": f2[key],
                                 "within": within}
        print(f"{label:26s} {f0[key]:8.3f} {f1[key]:8.3f} {f2[key]:10.3f}  {'yes' if within else 'NO'}")
    res["within_spread"] = ok
    res["candidate_bf16"] = bool(d2.get("bf16", False))
    print(f"\ncandidate within the fp32 ensemble's spread: {'yes' if ok else 'no'}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1, sort_keys=True)
        print(f"wrote {a.json}")


if __name__ == "__main__":
    main()
