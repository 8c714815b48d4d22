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
# Sized for ~20 min on 2 cores (the first 8 trajectories of valid and test_ratio, the 7
# built-ins for their first 3 s); --stride 10: n+1 / n+2 errors from every 10th frame
pick() { ls "$1" | grep '\.h5$' | head -8 | sed 's/\.h5$//' | sed 's/^/--trajectory /' | tr '\n' ' '; }
dcdc evaluate --model dcdc2d --model cconv2d --model out/inertial2d.pt --stride 10 $(pick "$DATA/valid") \
    --data "$DATA/valid" --json benchmarks/eval_2d_valid.json --plots out/eval_2d/valid
dcdc evaluate --model dcdc2d --model cconv2d --model out/inertial2d.pt --stride 10 --steps 150 \
    --data "$DATA/test_scenes" --json benchmarks/eval_2d_test_scenes.json --plots out/eval_2d/test_scenes
dcdc evaluate --model dcdc2d --model cconv2d --stride 10 $(pick "$DATA/test_ratio") \
    --data "$DATA/test_ratio" --json benchmarks/eval_2d_test_ratio.json --plots out/eval_2d/test_ratio
