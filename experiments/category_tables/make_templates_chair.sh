#!/usr/bin/env bash
# The paper's "templates, chair" table on the shared resampled ModelNet40 train chairs, K = 1 and 3
# (K = 5 would leave no test chair among the 5 shared ones): ours and every baseline (ICP; FGR,
# TEASER re-implementation and RANSAC with dictionary matching, as in the paper), then `experiments/_lib/category_table.py`:
# the chosen (rules cross_top_turns, the experiment's, cross, cross_top, score, density, agreement), oracle and
# random-template errors side by side (results/category/paper/templates_chair.{md,csv}), and ours'
# K = 3 views one by one (templates_chair_views.csv), and why each of its wrong views is wrong, at the
# registration and at the choice (experiments/_lib/why_wrong.py: templates_chair_why.{md,csv}).
# Usage (repository root): bash experiments/category_tables/make_templates_chair.sh [tables]
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
OUT=${OUT:-outputs/category}
if [ "${1:-}" != tables ]; then
  for e in mn40r_chair_1template mn40r_chair_ktemplates; do
    "$B" run -m +experiment=$e output_root="$OUT" progress=false print_summary=false \
      hydra.sweep.dir="$OUT/multirun/$e" ${EXTRA:-}
  done
fi
T=results/category/paper; mkdir -p "$T"
for fmt in md csv; do
  .venv/bin/python experiments/_lib/category_table.py --force "$OUT/multirun/mn40r_chair_1template" "$OUT/multirun/mn40r_chair_ktemplates" --category chair \
    --choices cross,cross_top,cross_top_turns,fused,score,density,agreement --format $fmt --out "$T/templates_chair.$fmt" \
    --title "Chair, K templates (shared resampled chairs; test views chair_0454, chair_0858 x 4)"
done
# ours' K = 3 views one by one: the chosen template's error beside the oracle's
.venv/bin/python experiments/category_tables/category_views.py "$OUT/multirun/mn40r_chair_ktemplates" --row ours \
  --out "$T/templates_chair_views.csv"
# why ours' wrong K = 3 views are wrong: the registration's score and the rule's cost against the truth's
.venv/bin/python experiments/_lib/why_wrong.py --force "$OUT/multirun/mn40r_chair_ktemplates" --row ours \
  --out "$T/templates_chair_why.md" --title "Why ours' wrong views are wrong: chair, K = 3 (fused), shared resampled chairs"
