#!/usr/bin/env bash
# `antisym2d` before and after its fine-tuning on the current teacher's 2-D data
# (docs/models.md, "antisym2d"), with the wall contact, on the sets of
# evaluate_2d.sh:   bash benchmarks/evaluate_antisym_2d.sh [DATA=datasets/2d_su]
# Writes benchmarks/results/eval_2d_{test_scenes,canyon10,valid,test_ratio}_antisym_<set>.json, <set>
# the data set's suffix (datasets/2d_bd -> _bd, the measurement in docs/models.md).
set -euo pipefail
DATA=${1:-datasets/2d_su}
SET=$(basename "$DATA"); SET=${SET#2d_}
export OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1
M="--model benchmarks/models/antisym2d_s1.pt --model benchmarks/models/antisym2d_s3.pt"
ev() { dcdc evaluate --stride 10 --overwrite --contact $M "$@" > /dev/null; }
ev --data "$DATA/test_scenes" --json benchmarks/results/eval_2d_test_scenes_antisym_$SET.json &
ev --data "$DATA/canyon10" --json benchmarks/results/eval_2d_canyon10_antisym_$SET.json &
wait
ev --data "$DATA/valid" --json benchmarks/results/eval_2d_valid_antisym_$SET.json &
ev --data "$DATA/test_ratio" --json benchmarks/results/eval_2d_test_ratio_antisym_$SET.json &
wait
python benchmarks/eval_tables.py benchmarks/results/eval_2d_*_antisym_$SET.json
