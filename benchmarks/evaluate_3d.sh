#!/usr/bin/env bash
# Scores of the shipped 3-D models against the SPH ground truth (docs/models.md):
#   bash benchmarks/evaluate_3d.sh [DATA=datasets/3d_su]
# Writes benchmarks/results/eval_3d_*.json and plots per trajectory in out/eval_3d/. Two
# evaluations run at a time, one thread each (2 cores). The inertial baseline is the same
# integrator with the learned correction switched off (every weight zero). Rollouts run
# with the wall contact (docs/evaluation.md); the n+1 / n+2 errors are the network alone.
# The showcases (cocktail, hourglass, canyon; 3-D, default resolution) are rolled out for
# SHOWCASE_STEPS steps (default 500 = 10 s, the stability target); lock exchange and
# dam break to the end of their SPH run.
set -euo pipefail
DATA=${1:-datasets/3d_su}
STEPS=${SHOWCASE_STEPS:-500}
export OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1
python benchmarks/inertial_model.py cconv3d out/inertial3d.pt
M="--model dcdc3d --model cconv3d"
I="--model out/inertial3d.pt"
ev() { dcdc evaluate --stride 10 --overwrite --contact "$@" > /dev/null; }
# the random validation and held-out-ratio scenes (ratios 10-20, outside training)
ev $M $I --data "$DATA/valid" --json benchmarks/results/eval_3d_valid.json --plots out/eval_3d/valid &
ev $M --data "$DATA/test_ratio" --json benchmarks/results/eval_3d_test_ratio.json --plots out/eval_3d/test_ratio &
wait
# the built-in scenes: the three showcases over $STEPS steps, lock exchange and dam break to the end
ev $M --data "$DATA/test_scenes" --trajectory cocktail_3d --trajectory hourglass_3d --steps "$STEPS" \
    --json benchmarks/results/eval_3d_showcases.json --plots out/eval_3d/showcases &
ev $M $I --data "$DATA/test_scenes" --trajectory lock_exchange_3d --trajectory dam_break_3d \
    --json benchmarks/results/eval_3d_test_scenes.json --plots out/eval_3d/test_scenes &
wait
# the canyon's own SPH run is 5 s; a 10 s one (DATA/canyon10, docs/datasets.md) for 500 steps
ev $M --data "$DATA/canyon10" --steps "$STEPS" --json benchmarks/results/eval_3d_canyon10.json \
    --plots out/eval_3d/canyon10 &
wait
# the showcases again from the SPH state at 0.2 s (frame 10), after the lattice start has
# settled onto the walls: separates the start-up burst from the rest of the dynamics
# (docs/models.md, "The cocktail's start-up burst")
ev $M --data "$DATA/test_scenes" --trajectory cocktail_3d --trajectory hourglass_3d --start-frame 10 \
    --steps "$((STEPS - 10))" --json benchmarks/results/eval_3d_showcases_from02s.json \
    --plots out/eval_3d/showcases_from02s &
ev $M --data "$DATA/canyon10" --start-frame 10 --steps "$((STEPS - 10))" \
    --json benchmarks/results/eval_3d_canyon10_from02s.json --plots out/eval_3d/canyon10_from02s &
wait
python benchmarks/eval_tables.py benchmarks/results/eval_3d_*.json
