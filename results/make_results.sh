#!/usr/bin/env bash
# Reproduces the committed tables in results/ on the embedded synthetic set (seed 0).
# Usage: bash results/make_results.sh   (from the repository root, after `make setup`)
# Runs resume: re-running skips finished samples. Takes ~20-30 min on 2 CPU cores.
set -euo pipefail
cd "$(dirname "$0")/.."
B=.venv/bin/bench
OUT=${OUT:-outputs/results}
run() { "$B" run dataset=synthetic seed=0 output_root="$OUT" progress=false print_summary=false "$@"; }

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

T=results/tables
mkdir -p "$T"
for fmt in md latex csv; do
  ext=$fmt; [ "$fmt" = latex ] && ext=tex
  "$B" table "$OUT/synthetic-gt_model" --layout optimizer --format $fmt --categories airplane,chair,car,mug,all \
    --out "$T/optimizer.$ext"
  "$B" table "$OUT/synthetic-gt_model" --layout generic --format $fmt --out "$T/gt_model_all.$ext"
  "$B" table "$OUT/synthetic-gt_model" --layout ablation --format $fmt --out "$T/ablation.$ext"
  "$B" table "$OUT/synthetic-templates" --layout templates --format $fmt --out "$T/templates.$ext"
  "$B" table "$OUT/synthetic-relative" --layout real --format $fmt --out "$T/relative.$ext"
done
"$B" report "$OUT/synthetic-gt_model" --out results/report --qualitative 1
