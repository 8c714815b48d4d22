#!/usr/bin/env bash
# The whole 2-D set the shipped 2-D networks train and are scored on, with the solver's
# current defaults (docs/datasets.md, "2-D"; 15-17 min on
# 2 cores):   bash benchmarks/regenerate_2d.sh [OUT=datasets/2d_su]
# The deep columns, necks and locks come from benchmarks/make_deep_columns.py's scene files
# (docs/datasets.md, "2-D"); they are written first if absent.
# No `set -e` on the generate lines: a diverged trajectory (recorded as NAME.failed.json)
# makes `dcdc generate` exit 1, and the next split must still run. Re-running resumes.
set -uo pipefail
OUT=${1:-datasets/2d_su}
S=datasets/2d
[ -d $S/deep_scenes ] || { for k in "50 0 tank" "50 0 glass" "40 0 neck"; do
    python benchmarks/make_deep_columns.py $S/deep_scenes $k; done; }
[ -d $S/lock_scenes ] || python benchmarks/make_deep_columns.py $S/lock_scenes 40 0 lock
[ -d $S/lock_scenes2 ] || python benchmarks/make_deep_columns.py $S/lock_scenes2 80 40 lock
t() { echo "$(date -u +%T) $*"; s=$(date +%s); "$@"; echo "$(date -u +%T) done in $(( $(date +%s) - s )) s"; }
t dcdc generate --dim 2 --random 200 --seed 0      --max-ratio 10 --split train --workers 2 -o $OUT/train
t dcdc generate --dim 2 --random 24  --seed 100000 --max-ratio 10 --split valid --workers 2 -o $OUT/valid
t dcdc generate --dim 2 $S/deep_scenes/*.toml --split train --workers 2 -o $OUT/deep
t dcdc generate --dim 2 $S/lock_scenes/*.toml --split train --workers 2 -o $OUT/deep_lock
t dcdc generate --dim 2 $S/lock_scenes2/*.toml --split train --workers 2 -o $OUT/deep_lock2
mkdir -p $OUT/train_deep3
for d in train deep deep_lock deep_lock2; do
    for f in $OUT/$d/*.h5; do ln -sf ../$d/${f##*/} $OUT/train_deep3/; done; done
t dcdc generate --dim 2 cocktail hourglass canyon dam_break double_dam_break rayleigh_taylor lock_exchange \
    --split test --workers 2 -o $OUT/test_scenes
t dcdc generate --dim 2 --random 20  --seed 200000 --density-range 250 5000 --min-ratio 10 --max-ratio 20 \
    --split test --workers 2 -o $OUT/test_ratio
t dcdc generate --dim 2 canyon --duration 10 --split test -o $OUT/canyon10
