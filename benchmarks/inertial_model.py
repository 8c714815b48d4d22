"""The inertial baseline of the evaluation scripts: a shipped model with every weight zero
(no learned correction: gravity and the integrator only), saved as a checkpoint.
    python benchmarks/inertial_model.py cconv2d out/inertial2d.pt"""
import os
import sys

import dcdc  # noqa: F401  (first: it sets the OpenMP wait policy torch reads on import)
import torch

from dcdc.model.checkpoint import load_checkpoint, save_checkpoint

name, out = sys.argv[1], sys.argv[2]
net, ck = load_checkpoint(name)
with torch.no_grad():
    for p in net.parameters():
        p.zero_()
os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
save_checkpoint(out, net, ck["data"], {"note": "all weights zero: no correction"})
