#!/usr/bin/env bash
# GPU measurements in one command, from a fresh checkout on a machine with a CUDA device
# (issue 10 item 5; budget < 5 min):
#   bash benchmarks/gpu.sh
# Writes benchmarks/results/model_gpu.json (ms per 3-D neural step at 1 k - 100 k particles, the
# network on the GPU, search + geometry on the CPU) and benchmarks/results/table1_gpu.json (the
# paper's Table 1, 2-D and 3-D showcases, with the network on the GPU; the SPH solver runs on the CPU cores).
# CI never has a GPU and nothing depends on this script.
set -euo pipefail
cd "$(dirname "$0")/.."
if python3 -c "import torch, numba, h5py, click, tqdm, matplotlib, scipy" 2>/dev/null \
        && python3 -c "import torch, sys; sys.exit(not torch.cuda.is_available())"; then
    # an image that already holds torch with CUDA (e.g. an offline GPU machine): run from
    # the checkout with its packages; the benchmarks import nothing else
    export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
    dcdc() { python3 -c "from dcdc.cli import main; main()" "$@"; }
else
    python3 -m venv .venv-gpu
    . .venv-gpu/bin/activate
    # PyPI's Linux wheel of torch==2.13.0 (the pinned version) carries CUDA; the CPU
    # machines install the CPU build of the same version from their package index instead
    pip install -q -e .
fi
python3 - <<'PY'
import sys, torch
if not torch.cuda.is_available():
    sys.exit(f"error: torch {torch.__version__} sees no CUDA device")
print(torch.cuda.get_device_name(0), torch.version.cuda)
PY
dcdc benchmark model --device cuda --particles 1000,10000,50000,100000 --repeat 10 \
    --json benchmarks/results/model_gpu.json
dcdc benchmark table1 --device cuda --model3d dcdc3d --json benchmarks/results/table1_gpu.json \
    --note "network on $(python3 -c 'import torch; print(torch.cuda.get_device_name(0))'), SPH on $(nproc) CPU cores"
