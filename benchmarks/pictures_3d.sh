#!/usr/bin/env bash
# SPH-above-learned-model strips of the 3-D showcases (docs/models.md, README):
#   bash benchmarks/pictures_3d.sh [DATA=datasets/3d_su] [MODEL=dcdc3d] [SCENES="cocktail hourglass canyon"]
# Rolls the model out from each SPH trajectory's first frame (wall contact on) for up to
# 500 steps into out/pictures/, then draws docs/img/compare_<scene>_3d.png (a cut-away
# through the middle, so the layers inside the container are visible).
set -euo pipefail
DATA=${1:-datasets/3d_su}
MODEL=${2:-dcdc3d}
SCENES=${3:-cocktail hourglass canyon}
mkdir -p out/pictures
for s in $SCENES; do
    # the canyon's 10 s SPH run is DATA/canyon10 (docs/datasets.md)
    case $s in canyon) set=canyon10; strip=0,1,2,4,6,10 ;; *) set=test_scenes; strip=0,1,3,6,10 ;; esac
    dcdc simulate --model "$MODEL" --dataset "$DATA/$set" --trajectory "${s}_3d" --steps 500 \
        --out "out/pictures/${s}_3d_$MODEL.h5" --overwrite > /dev/null 2>&1 || true  # a guard stop is drawn too
    dcdc render --compare "$DATA/$set/${s}_3d.h5" "out/pictures/${s}_3d_$MODEL.h5" --strip "$strip" \
        --cut z --out "docs/img/compare_${s}_3d.png" --overwrite --no-progress
done
