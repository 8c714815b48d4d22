#!/usr/bin/env bash
# The whole 3-D set the shipped 3-D networks are scored on (stage 7 trained on it), with the solver's
# current defaults (docs/datasets.md, "3-D"; 33 min on
# the idle 2-core machine):   bash benchmarks/regenerate_3d.sh [OUT=datasets/3d_su] [PART=all|train|test]
# PART=train writes what fine-tuning needs (random train + valid, the 133 deep columns);
# PART=test the held-out ratios, the built-ins and the 10 s canyon. The deep columns come
# from benchmarks/make_deep_columns.py's scene files (docs/models.md, "Fine-tuning on deep
# columns"), written first if absent: the 63 box tanks used (seeds 0, 1, 10-15, 100-154)
# and 70 stemmed glasses (seeds 0-69).
# No `set -e` on the generate lines: a diverged trajectory (recorded as NAME.failed.json)
# makes `dcdc generate` exit 1, and the next split must still run. Re-running resumes.
set -uo pipefail
OUT=${1:-datasets/3d_su}
PART=${2:-all}
S=datasets/3d_scenes
[ -d $S/deep ] || python benchmarks/make_deep_columns.py $S/deep 160 0
[ -d $S/glass ] || python benchmarks/make_deep_columns.py $S/glass 70 0 glass
t() { echo "$(date -u +%T) $*"; s=$(date +%s); "$@"; echo "$(date -u +%T) done in $(( $(date +%s) - s )) s"; }
if [ "$PART" != test ]; then
t dcdc generate --dim 3 --random 120 --seed 0      --max-ratio 10 --split train --workers 2 -o $OUT/train
t dcdc generate --dim 3 --random 16  --seed 100000 --max-ratio 10 --split valid --workers 2 -o $OUT/valid
t dcdc generate --dim 3 $S/deep/deep_column_{0,1,1[0-5],1[0-4][0-9],15[0-4]}.toml --split train \
    --workers 2 -o $OUT/deep_v2
t dcdc generate --dim 3 $S/glass/*.toml --split train --workers 2 -o $OUT/deep_glass
mkdir -p $OUT/train_deep_v2
for d in train deep_v2 deep_glass; do
    for f in $OUT/$d/*.h5; do ln -sf ../$d/${f##*/} $OUT/train_deep_v2/; done; done
fi
if [ "$PART" != train ]; then
t dcdc generate --dim 3 --random 10  --seed 200000 --density-range 250 5000 --min-ratio 10 --max-ratio 20 \
    --split test --workers 2 -o $OUT/test_ratio
t dcdc generate --dim 3 canyon hourglass cocktail lock_exchange dam_break --split test --workers 2 \
    -o $OUT/test_scenes
t dcdc generate --dim 3 canyon --duration 10 --split test -o $OUT/canyon10
fi
