#!/usr/bin/env bash
# Ours at its defaults on the report data of the search study (README.md), with found@10, and why
# each wrong estimate is wrong (never found / found, not chosen; search miss / ambiguous):
#   results/search_recall/clutter_ours.md (+ _objects): clutter report scenes, both object halves;
#   results/search_recall/clutter_ours_dev.md: the dev scenes the choice was made on (a record);
#   results/search_recall/real_ours.md (+ _objects): the shared real frames, TYO-L, ModelNet40;
#   results/search_recall/ambiguity_clutter.md, ambiguity_ycbv.md, ambiguity_tyol.md.
# Run from the repository root; resumes. Environment: RUNS (default outputs), PY, BENCH.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
RUNS=${RUNS:-outputs}
R=results/search_recall
eval "$($PY -m catpose.bench.run.environment portable)"
$BENCH suite clutter --force --methods ours --parts report,report_A,report_B --output-root "$RUNS/clutter" \
  --write $R/clutter_ours.md --objects $R/clutter_ours_objects.md
$BENCH suite clutter --force --methods ours --parts dev,dev_A,dev_B --output-root "$RUNS/clutter" --write $R/clutter_ours_dev.md
$BENCH suite real --force --methods ours --output-root "$RUNS/real" --write $R/real_ours.md --objects $R/real_ours_objects.md
source experiments/default_runs.sh  # ours' default runs only (no method.* override), the newest of each
# shellcheck disable=SC2046  # one argument per run directory
$PY experiments/_lib/ambiguity.py $(default_runs "$RUNS/clutter/clutter-gt_model/ours") --split clutter_objects --force \
  --out $R/ambiguity_clutter.md --title "Clutter report and dev scenes, uniform resting poses: ours' wrong estimates"
# shellcheck disable=SC2046
$PY experiments/_lib/ambiguity.py $(default_runs "$RUNS/real/ycbv-gt_model/ours") --split ycbv --force \
  --out $R/ambiguity_ycbv.md --title "Shared real YCB-V frames: ours' wrong estimates"
# shellcheck disable=SC2046
$PY experiments/_lib/ambiguity.py $(default_runs "$RUNS/real/bop-gt_model/ours") --force \
  --out $R/ambiguity_tyol.md --title "The TYO-L frame: ours' wrong estimate"
