#!/usr/bin/env bash
# Reproduces the committed tables in results/ on the embedded synthetic set (seed 0): one sweep per
# paper table (configs/experiment/<table>.yaml), then its tables from the sweep's files.
# Usage: bash results/make_results.sh [tables]   (repository root, after `make setup`; `tables`: only
# rebuild the tables and report from existing sweeps)
# Runs resume: re-running skips finished samples. Takes ~20-30 min on 2 CPU cores; with the cluster
# extra (`make cluster`) add e.g. LAUNCHER=hydra/launcher=local_procs, or =slurm on a cluster.
set -euo pipefail
cd "$(dirname "$0")/.."
B=.venv/bin/bench
OUT=${OUT:-outputs/results}
S=$OUT/multirun  # named sweep directories, so a re-run resumes into the same ones
EXPERIMENTS=(optimiser ablation one_template templates relative_real tyol)

if [ "${1:-}" != tables ]; then
  for e in "${EXPERIMENTS[@]}"; do
    "$B" run -m +experiment=$e dataset=synthetic seed=0 output_root="$OUT" progress=false print_summary=false \
      hydra.sweep.dir="$S/$e" ${LAUNCHER:-}
  done
fi

T=results/tables
mkdir -p "$T"
for fmt in md latex csv; do
  ext=$fmt; [ "$fmt" = latex ] && ext=tex
  for e in optimiser ablation one_template templates tyol; do
    "$B" table --sweep "$S/$e" --format $fmt --out "$T/$e.$ext"
  done
  "$B" table --sweep "$S/optimiser" --layout generic --format $fmt --out "$T/gt_model_all.$ext"
  "$B" table --sweep "$S/templates" --layout generic --format $fmt --error err_deg \
    --title "Category templates (3 other instances; estimate chosen by the method's own score)" --out "$T/templates_selected.$ext"
  "$B" table --sweep "$S/templates" --layout generic --format $fmt --error oracle_err_deg \
    --title "Category templates: minimum error across templates (oracle, the paper's Table templatechair)" --out "$T/templates_oracle.$ext"
  "$B" table --sweep "$S/relative_real" --layout generic --format $fmt \
    --title "Relative pose between two views of one object, each registered to the category templates" --out "$T/relative.$ext"
done
G="$OUT/synthetic-gt_model"
"$B" report "$G/icp" "$G/ours" --label "$(ls -d "$G"/ours/seed0-+row=ours-*)=Ours" --out results/report --qualitative 1
