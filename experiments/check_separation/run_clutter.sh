#!/usr/bin/env bash
# Ours on the clutter dev scenes 0-14 with segmenter-like masks (dataset.mask_noise=1), seeds 0-2, into
# $OUT/seed<k> (finished runs are kept), then @10 per seed and the seeds' agreement (agree.py).
# Usage: OUT=outputs/check_separation/clutter-<label> bash experiments/check_separation/run_clutter.sh [override ...]
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
OUT=${OUT:-outputs/check_separation/clutter}
for seed in 0 1 2; do
  nice "$BENCH" run method=ours dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 14)]" \
    dataset.mask_noise=1.0 seed=$seed threads=1 output_root="$OUT/seed$seed" progress=false print_summary=false "$@"
done
.venv/bin/python experiments/check_separation/agree.py $(find "$OUT" -name samples.jsonl -printf '%h\n' | sort)
