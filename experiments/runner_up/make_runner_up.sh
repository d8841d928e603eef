#!/usr/bin/env bash
# Ours' runner-up and its margin (README.md): ours at its defaults, seed 0, into its own run folders
# (runs of an older ours lack the runner-up), then results/runner_up/dev.md (the margin, chosen on the
# clutter dev scenes 0-99 and 200-399) and results/runner_up/report.md (the clutter report scenes and
# their object halves, the shared YCB-V frames per scene, the TYO-L frame, the embedded set's seed 0).
# Usage: bash experiments/runner_up/make_runner_up.sh   (repository root, after `make setup`; ~5 min on
# 2 cores; resumes). Environment: RUNS (default outputs/runner_up), RESULTS (default results).
# Needs ../shared/data (or $CATPOSE_SHARED_DATA); skips with a note without it.
set -euo pipefail
cd "$(dirname "$0")/../.."
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
RUNS=${RUNS:-outputs/runner_up}
RESULTS=${RESULTS:-results}
B=.venv/bin/bench
PY=.venv/bin/python
if [ ! -d "$SHARED/bop/ycbv/models" ]; then
  echo "make_runner_up: no $SHARED/bop/ycbv/models; skipped (set CATPOSE_SHARED_DATA)" >&2
  exit 0
fi
eval "$($PY -m catpose.bench.run.environment portable)"
Q=(method=ours seed=0 progress=false print_summary=false)
ran() { ls -d "$1"/*/ | head -1 | sed 's:/$::'; }  # the one run directory below a folder
$B run "${Q[@]}" dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 199)]" \
  "output_root=$RUNS/clutter" > /dev/null
$B run "${Q[@]}" dataset=clutter "dataset.root=$SHARED/bop/ycbv" dataset.num_scenes=400 \
  "dataset.scenes=[$(seq -s, 200 399)]" "output_root=$RUNS/clutter_dev2" > /dev/null
$B run "${Q[@]}" dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "output_root=$RUNS/ycbv" > /dev/null
$B run "${Q[@]}" dataset=bop "dataset.root=$SHARED/bop/tyol" "output_root=$RUNS/tyol" > /dev/null
$B run "${Q[@]}" dataset=synthetic protocol=gt_model "output_root=$RUNS/synthetic" > /dev/null
C=$(ran "$RUNS/clutter/clutter-gt_model/ours")
D=$(ran "$RUNS/clutter_dev2/clutter-gt_model/ours")
Y=$(ran "$RUNS/ycbv/ycbv-gt_model/ours")
$PY experiments/runner_up/runner_up.py --force --out-dir "$RESULTS/runner_up" \
  --choose "clutter dev scenes 0-99=$C@clutter:dev" "clutter scenes 200-399=$D" \
  --report "clutter report scenes=$C@clutter:report" "clutter report, objects A=$C@clutter_objects:report_A" \
  "clutter report, objects B=$C@clutter_objects:report_B" "YCB-V scene 1=$Y@ycbv:scene1" \
  "YCB-V scene 2=$Y@ycbv:scene2" "TYO-L=$(ran "$RUNS/tyol/bop-gt_model/ours")" \
  "embedded set, seed 0=$(ran "$RUNS/synthetic/synthetic-gt_model/ours")"
