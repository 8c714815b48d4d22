#!/usr/bin/env bash
# Scores of the shipped 2-D models against the SPH ground truth (docs/models.md):
#   bash benchmarks/evaluate_2d.sh [DATA=datasets/2d]
# Writes benchmarks/eval_2d_{valid,test_ratio,test_scenes}.json, plots per trajectory in out/eval_2d/.
# The inertial baseline is the same integrator with the learned correction switched off
# (every weight zero): x += Δt v + Δt² g, then nothing; it shows what the network adds.
set -euo pipefail
DATA=${1:-datasets/2d}
python - <<'PY'
import torch
from dcdc.model.checkpoint import load_checkpoint, save_checkpoint
net, ck = load_checkpoint("cconv2d")
with torch.no_grad():
    for p in net.parameters():
        p.zero_()
import os
os.makedirs("out", exist_ok=True)
save_checkpoint("out/inertial2d.pt", net, ck["data"], {"note": "all weights zero: no correction"})
PY
for split in valid test_ratio test_scenes; do
  dcdc evaluate --model dcdc2d --model cconv2d --model out/inertial2d.pt \
      --data "$DATA/$split" --json "benchmarks/eval_2d_$split.json" --plots "out/eval_2d/$split"
done
