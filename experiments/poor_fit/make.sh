#!/usr/bin/env bash
# experiments/poor_fit (README.md): ours with depth_min_inliers 0.95 (default), 0.9, 0.85 and 0 on the dev
# parts (key_audit's harness: clutter dev 0-49 and YCB-V scene 1, dirty masks, and YCB-V scene 1 written;
# seeds 0-2) into outputs/poor_fit/, then results/poor_fit/dev.md; and with the category templates (the
# embedded set's seeds 1-3; YCB-V scene 1, seeds 0-2) into outputs/poor_fit/{templates,ycbv_templates}/,
# then results/poor_fit/templates.md and ycbv_templates.md.
# Usage (repository root): bash experiments/poor_fit/make.sh   (PARTS as key_audit's make.sh; SKIP_TEMPLATES=1)
set -euo pipefail
source experiments/_lib/seed_tables.sh
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
OUT=${OUT:-outputs/poor_fit}
VALUES="0.95 0.9 0.85 0"
BATCHES="default,depth_min_inliers 0,depth_min_inliers 0.9,depth_min_inliers 0.85" OUT=$OUT NO_TABLE=1 \
  bash experiments/key_audit/make.sh
mkdir -p results/poor_fit
.venv/bin/python experiments/key_audit/table.py "$OUT" results/poor_fit/dev.md experiments/poor_fit/README.md
[ -n "${SKIP_TEMPLATES:-}" ] && exit 0
AXES=$(for c in can bottle bowl mug; do printf '+dataset.symmetric.%s=[0,0,1] ' $c; done)
for v in $VALUES; do
  for seed in 1 2 3; do
    nice -n 5 .venv/bin/bench run method=ours dataset=synthetic protocol=templates seed=$seed \
      output_root="$OUT/templates/inliers$v-seed$seed" progress=false print_summary=false \
      method.selection.depth_min_inliers=$v
  done
  for seed in 0 1 2; do
    # shellcheck disable=SC2086  # the overrides are words
    nice -n 5 .venv/bin/bench run method=ours dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]" \
      protocol=templates $AXES seed=$seed output_root="$OUT/ycbv_templates/inliers$v-seed$seed" \
      progress=false print_summary=false method.selection.depth_min_inliers=$v
  done
done
seed_tables "$OUT" results/poor_fit
