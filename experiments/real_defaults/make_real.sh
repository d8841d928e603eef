#!/usr/bin/env bash
# Every method on the shared real data (../shared/data or $CATPOSE_SHARED_DATA), one table with a
# column per YCB-V scene (configs/split/ycbv.yaml: fold A chooses on scene 1 and reports scene 2,
# fold B the reverse; ours' issue-22 choices were made on the synthetic clutter set, so both scene
# columns are scenes not used for choosing), and per-object tables of each scene.
# Run from the repository root; resumes (finished samples are skipped).
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
# seed 0 (the README's table, results/real/headline.md, pools seeds 0-2: section `real` of results/make_results.sh)
$BENCH suite real --force --sets ycbv,tyol,modelnet40_resampled,redwood --seeds 0 --write results/real/table.md \
  --objects results/real/objects.md
