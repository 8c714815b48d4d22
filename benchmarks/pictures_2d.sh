#!/usr/bin/env bash
# The SPH-above-learned-model strips of docs/models.md and the README:
#   bash benchmarks/pictures_2d.sh [DATA=datasets/2d_su] [MODEL=dcdc2d]
# Rolls the model out from each SPH trajectory's first frame (the model's own wall-contact
# default: dcdc2d alone) into
# out/pictures/, then draws docs/img/compare_<scene>_2d.png with dcdc render --compare.
set -euo pipefail
DATA=${1:-datasets/2d_su}
MODEL=${2:-dcdc2d}
mkdir -p out/pictures
pic() {  # scene, dataset, strip times
    dcdc simulate --model "$MODEL" --dataset "$DATA/$2" --trajectory "$1_2d" \
        --out "out/pictures/$1_$MODEL.h5" --overwrite > /dev/null 2>&1 || true  # a guard stop is drawn too
    dcdc render --compare "$DATA/$2/$1_2d.h5" "out/pictures/$1_$MODEL.h5" --strip "$3" \
        --out "docs/img/compare_$1_2d.png" --overwrite
}
pic cocktail test_scenes 0,1,3,6,10,15
pic hourglass test_scenes 0,1,3,6,10,15
pic canyon test_scenes 0,1,2,3,4,5  # the 10-s run (canyon10) is refused by the current teacher
pic lock_exchange test_scenes 0,1,2,3,4
pic dam_break test_scenes 0,0.5,1,2,3
