#!/usr/bin/env bash
# Scores of the shipped 2-D models against the SPH ground truth (docs/models.md):
#   bash benchmarks/evaluate_2d.sh [DATA=datasets/2d_su]
# Writes benchmarks/results/eval_2d_*.json and plots per trajectory in out/eval_2d/. Two
# evaluations run at a time, one thread each (2 cores); ~25 min on the idle 2-core machine.
# The inertial baseline is the same integrator with the learned correction switched off
# (every weight zero): x += Δt v + Δt² g, then nothing; it shows what the network adds.
# Rollouts run with the walls' wall contact (docs/evaluation.md) unless the file name says
# nocontact; the n+1 / n+2 errors are the network alone either way.
set -euo pipefail
DATA=${1:-datasets/2d_su}
export OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1
python benchmarks/inertial_model.py cconv2d out/inertial2d.pt
M="--model dcdc2d --model cconv2d"
I="--model out/inertial2d.pt"
ev() { dcdc evaluate --stride 10 --overwrite "$@" > /dev/null; }
# with the wall contact (the inertial baseline beside the networks, plots), then without
for mode in contact nocontact; do
    if [ $mode = contact ]; then flag="--contact"; sfx=""; base="$I"; else flag="--no-contact"; sfx="_nocontact"; base=""; fi
    plots() { [ $mode = contact ] && echo "--plots out/eval_2d/$1" || true; }
    # the 7 built-ins to the end of their SPH run (cocktail, hourglass 750 steps); the
    # canyon over 500 steps where DATA/canyon10 exists (dcdc generate canyon --dim 2
    # --duration 10: the current teacher refuses it, a spray pair merges at 7.7 s, docs/sph.md)
    ev $M $base $flag --data "$DATA/test_scenes" --json "benchmarks/results/eval_2d_test_scenes$sfx.json" $(plots test_scenes) &
    if [ -d "$DATA/canyon10" ]; then
        ev $M $flag --data "$DATA/canyon10" --json "benchmarks/results/eval_2d_canyon10$sfx.json" $(plots canyon10) &
    fi
    wait
    # all 24 validation and all 18 held-out (ratios 11-19) random scenes
    ev $M $base $flag --data "$DATA/valid" --json "benchmarks/results/eval_2d_valid$sfx.json" $(plots valid) &
    ev $M $flag --data "$DATA/test_ratio" --json "benchmarks/results/eval_2d_test_ratio$sfx.json" $(plots test_ratio) &
    wait
done
python benchmarks/eval_tables.py benchmarks/results/eval_2d_*.json
