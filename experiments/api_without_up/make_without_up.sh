#!/usr/bin/env bash
# catpose.register without `up` (the ground normal), method=ours, protocol=gt_model:
#  - without_up_seed0_dev.md: development set (synthetic seed 0, 48 views) on which the number of up
#    hypotheses tried (catpose.api.UP_HYPOTHESES) was chosen;
#  - without_up_seed1.md: report set, other synthetic scenes (seed 1, 48 views);
#  - without_up_modelnet40_resampled.md: report set, the shared ModelNet40 resampled train-split
#    shapes (46 views), when ../shared/data is beside the checkout.
# Usage: bash experiments/api_without_up/make_without_up.sh   (repository root, after `make setup`; ~1.5 h on 2 cores)
# Figures are this machine's default code paths (no portable profile); seconds are wall-clock on a
# shared machine and only compare the rows of one table.
set -euo pipefail
cd "$(dirname "$0")/../.."
PY=.venv/bin/python
S=experiments/api_without_up/api_without_up.py
nice $PY $S --seed 0 --hypotheses 6,12,24,48 --out results/api/without_up_seed0_dev.md
nice $PY $S --seed 1 --hypotheses 24 --out results/api/without_up_seed1.md
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
if [ -d "$SHARED/modelnet40_normal_resampled" ]; then
  nice $PY $S --dataset modelnet40_resampled --override "dataset.root=$SHARED/modelnet40_normal_resampled" \
    --hypotheses 24 --out results/api/without_up_modelnet40_resampled.md
fi
