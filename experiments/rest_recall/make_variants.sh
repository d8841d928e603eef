#!/usr/bin/env bash
# The search's variants explored on the clutter dev scenes 0-49 (dirty masks, dataset.mask_noise=1), seeds 0-2,
# against today's defaults (make.sh dev base, restricted to the same views) -> results/rest_recall/dev_variants.md.
# Runs go to outputs/rest_recall/x_LABEL/ (finished samples are kept). Usage (repository root):
#   bash experiments/rest_recall/make_variants.sh
set -euo pipefail
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
run() {
  local label=$1; shift
  for seed in 0 1 2; do
    nice -n 5 .venv/bin/python experiments/rest_recall/rest_recall.py "outputs/rest_recall/x_$label/clutter_dev-seed$seed.jsonl" \
      "$seed" dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]" "dataset.mask_noise=${MASK:-1.0}" "$@"
  done
}
run beam0 method.resting.grid_beam=0      # every grid pose refined in one pass (no Chamfer beam)
run yaws12 method.resting.grid_yaws=12    # 12 yaws per resting direction instead of 8
run keep_all const:rest_search.KEEP=100000  # every pose of the search into the pool: what the grid itself held
MASK=0.0 run clean                        # the defaults with the written (clean) masks: what the dirt costs
.venv/bin/python experiments/rest_recall/variants.py results/rest_recall/dev_variants.md \
  "Rest recall: the coarse search's variants, clutter dev scenes 0-49, dirty masks" \
  "default=outputs/rest_recall/base/clutter_dev-seed*.jsonl" \
  "grid_beam 0=outputs/rest_recall/x_beam0/clutter_dev-seed*.jsonl" \
  "grid_yaws 12=outputs/rest_recall/x_yaws12/clutter_dev-seed*.jsonl" \
  "every search pose in the pool (KEEP 100000)=outputs/rest_recall/x_keep_all/clutter_dev-seed*.jsonl" \
  "defaults, clean masks (mask_noise 0)=outputs/rest_recall/x_clean/clutter_dev-seed*.jsonl"
