#!/usr/bin/env bash
# What segmenter-like masks do (dataset.mask_noise, datasets/mask_noise.py): ours and ICP on the clutter
# dev scenes 0-14 (configs/split/clutter.yaml `dev`), the written masks (mask_noise 0) and corrupted ones
# (strength up to 1), seeds 0-2 -> results/mask_noise/clutter_dev.md (README.md). Needs
# ../shared/data/bop/ycbv/models (or $CATPOSE_SHARED_DATA). ~10 min on two cores; finished runs are kept.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
OUT=${OUT:-outputs/mask_noise}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
eval "$($PY -m catpose.bench.run.environment portable)"
LABELS=() DIRS=()
for method in ours icp; do
  for noise in 0.0 1.0; do
    for seed in 0 1 2; do
      dir="$OUT/$method-noise$noise-seed$seed"
      "$BENCH" run method=$method dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 14)]" \
        dataset.mask_noise=$noise seed=$seed threads=1 output_root="$dir" progress=false print_summary=false
      LABELS+=(--label "$(dirname "$(find "$dir" -name samples.jsonl | head -1)")=$method, mask_noise $noise, seed $seed")
      DIRS+=("$dir")
    done
  done
done
"$BENCH" table --force "${DIRS[@]}" "${LABELS[@]}" --layout generic --categories all \
  --metrics n,mean,median,acc10,acc30 \
  --title "Clutter dev scenes 0-14: the written masks and segmenter-like ones (dataset.mask_noise), seeds 0-2" \
  --out results/mask_noise/clutter_dev.md
