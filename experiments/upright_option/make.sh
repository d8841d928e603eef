#!/usr/bin/env bash
# Ours at its defaults against ours with the user option "my objects stand on the template's up"
# (method.resting.max_poses=0: the coarse search and the gravity filter know only the template's own up),
# on the shared real frames: YCB-V scenes 1 and 2 (written masks and segmenter-like masks) under seeds 0-2,
# the TYO-L basket under seeds 0-4 (dataset=bop, own model); `bench run` per variant and seed into
# outputs/upright_option (finished runs resume), then results/upright_option/real.md (table.py).
# Usage (repository root): bash experiments/upright_option/make.sh      (~10 min on two cores)
set -euo pipefail
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
B=.venv/bin/bench
OUT=${OUT:-outputs/upright_option}
Q=(method=ours progress=false print_summary=false)
for variant in default upright; do
  opt=(); [ $variant = upright ] && opt=(method.resting.max_poses=0)
  for seed in 0 1 2; do
    for noise in 0.0 1.0; do
      $B run "${Q[@]}" ${opt[@]+"${opt[@]}"} dataset=ycbv "dataset.root=$SHARED/bop/ycbv" dataset.mask_noise=$noise \
        seed=$seed "output_root=$OUT/$variant/ycbv-noise$noise" 2>/dev/null
    done
  done
  for seed in 0 1 2 3 4; do
    $B run "${Q[@]}" ${opt[@]+"${opt[@]}"} dataset=bop "dataset.root=$SHARED/bop/tyol" seed=$seed \
      "output_root=$OUT/$variant/tyol" 2>/dev/null
  done
done
.venv/bin/python experiments/upright_option/table.py "$OUT" results/upright_option/real.md
