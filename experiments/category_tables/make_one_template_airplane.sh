#!/usr/bin/env bash
# The paper's "one template, airplane" table on the shared resampled ModelNet40 train airplanes:
# ours and every baseline (ICP; FGR, TEASER re-implementation and RANSAC, direct and dictionary
# matching) in one sweep (configs/experiment/mn40r_airplane_1template.yaml), then the table and the
# per-view errors of ours (results/category/paper/one_template_airplane.{md,csv},
# paper/one_template_airplane_views.csv). Then the same sweep under the one-template turn check
# (choice=cross_top_turns, choice.turns_deg=[180], choice.one_template_turns=true: each estimate or its half turn about up,
# chosen on procedural airplanes, docs/category-level.md): one_template_airplane_turns.{md,csv},
# one_template_airplane_turns_views.csv. Last, why each of ours' wrong views is wrong, at the step that chose
# it (experiments/_lib/why_wrong.py): one_template_airplane_why.{md,csv}.
# Usage (repository root, after `make setup`): bash experiments/category_tables/make_one_template_airplane.sh [tables]
# Extra Hydra overrides go in EXTRA (e.g. EXTRA="dataset.root=/data/modelnet40_normal_resampled ...").
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
OUT=${OUT:-outputs/category}
S=$OUT/multirun/mn40r_airplane_1template
ST=$OUT/multirun/mn40r_airplane_1template_turns
TURNS=(choice=cross_top_turns "choice.turns_deg=[180]" choice.one_template_turns=true)
if [ "${1:-}" != tables ]; then
  "$B" run -m +experiment=mn40r_airplane_1template output_root="$OUT" progress=false print_summary=false \
    hydra.sweep.dir="$S" ${EXTRA:-}
  "$B" run -m +experiment=mn40r_airplane_1template "${TURNS[@]}" output_root="$OUT" progress=false print_summary=false \
    hydra.sweep.dir="$ST" ${EXTRA:-}
fi
T=results/category/paper; mkdir -p "$T"
for fmt in md csv; do
  "$B" table --force --sweep "$S" --layout one_template --format $fmt --metrics mean,median,acc10,acc30,trans,n,failed \
    --title "One template (airplane_0536), shared resampled airplanes (17 x 2 views)" --out "$T/one_template_airplane.$fmt"
done
.venv/bin/python experiments/category_tables/category_views.py "$S" --row ours --out "$T/one_template_airplane_views.csv"
for fmt in md csv; do
  "$B" table --force --sweep "$ST" --layout one_template --format $fmt --metrics mean,median,acc10,acc30,trans,n,failed \
    --title "One template (airplane_0536) with the half-turn check (cross_top_turns, turns 180), shared resampled airplanes (17 x 2 views)" \
    --out "$T/one_template_airplane_turns.$fmt"
done
.venv/bin/python experiments/category_tables/category_views.py "$ST" --row ours --out "$T/one_template_airplane_turns_views.csv"
# why ours' wrong views are wrong: its own score of the estimate against the truth's (docs/category-level.md)
.venv/bin/python experiments/_lib/why_wrong.py --force "$S" --row ours --out "$T/one_template_airplane_why.md" \
  --title "Why ours' wrong views are wrong: one template (airplane_0536), shared resampled airplanes"
