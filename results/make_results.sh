#!/usr/bin/env bash
# Reproduces the committed tables in results/ on the embedded synthetic set (seed 0).
# Usage: bash results/make_results.sh [tables]   (repository root, after `make setup`; `tables`: only
# rebuild the tables and report from existing runs)
# Runs resume: re-running skips finished samples. Takes ~20-30 min on 2 CPU cores.
set -euo pipefail
cd "$(dirname "$0")/.."
B=.venv/bin/bench
OUT=${OUT:-outputs/results}
run() { "$B" run dataset=synthetic seed=0 output_root="$OUT" progress=false print_summary=false "$@"; }

if [ "${1:-}" != tables ]; then
# Table "optimizer": each view against its own complete model (protocol=gt_model)
run method=icp
run method=ours
run method=ours method.optimize=none          # ablation: SVD initial pose only
run method=ours method.optimize=pose          # ablation: stage 1 only
run method=ours method.descriptor=pfh
for m in fgr teaser; do
  run method=$m method.matching=direct method.features=fpfh
  run method=$m method.matching=dictionary method.features=fpfh
  run method=$m method.matching=dictionary method.features=lps
done
run method=ransac method.matching=dictionary method.features=fpfh

# Category level: each view against 3 other instances of its category (protocol=templates),
# and against the first one only
for m in icp ours; do
  run method=$m protocol=templates
  run method=$m protocol=templates protocol.max_templates=1
done
run method=teaser protocol=templates method.matching=dictionary method.features=fpfh

# Relative pose between two views of one object, each registered to the category templates
for m in icp ours; do
  run method=$m protocol=relative
done

fi

T=results/tables
G="$OUT/synthetic-gt_model"
L=(--label "$(ls -d $G/ours/seed0-default-*)=Ours"
   --label "$(ls -d $G/ours/seed0-method.optimize=pose-*)=Ours (stage 1 only)"
   --label "$(ls -d $G/ours/seed0-method.optimize=none-*)=Ours (w/o optimization)"
   --label "$(ls -d $G/ours/seed0-method.descriptor=pfh-*)=Ours (PFH)")
mkdir -p "$T"
for fmt in md latex csv; do
  ext=$fmt; [ "$fmt" = latex ] && ext=tex
  "$B" table "$G" "${L[@]}" --layout optimizer --format $fmt --categories airplane,chair,car,mug,all --out "$T/optimizer.$ext"
  "$B" table "$G" "${L[@]}" --layout generic --format $fmt --out "$T/gt_model_all.$ext"
  "$B" table "$G/ours" "${L[@]}" --layout ablation --format $fmt --out "$T/ablation.$ext"
  "$B" table "$OUT/synthetic-templates" --layout generic --format $fmt --error err_deg \
    --title "Category templates (3 other instances; estimate chosen by the method's own score)" --out "$T/templates_selected.$ext"
  "$B" table "$OUT/synthetic-templates" --layout generic --format $fmt --error oracle_err_deg \
    --title "Category templates: minimum error across templates (oracle, the paper's Table templatechair)" --out "$T/templates_oracle.$ext"
  "$B" table "$OUT/synthetic-relative" --layout generic --format $fmt \
    --title "Relative pose between two views of one object, each registered to the category templates" --out "$T/relative.$ext"
done
"$B" report "$G/icp" "$G/ours" "${L[@]}" --out results/report --qualitative 1
