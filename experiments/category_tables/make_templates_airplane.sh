#!/usr/bin/env bash
# Airplanes against K = 1, 3, 5 templates on the shared resampled train airplanes (same 22 test views
# for every K; configs/experiment/mn40r_airplane_ktemplates.yaml): ours, ICP, FGR and TEASER
# (dictionary), chosen / oracle / random side by side (results/category/paper/templates_airplane.{md,csv}).
# Usage (repository root): bash experiments/category_tables/make_templates_airplane.sh [tables]
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
OUT=${OUT:-outputs/category}
S=$OUT/multirun/mn40r_airplane_ktemplates
if [ "${1:-}" != tables ]; then
  "$B" run -m +experiment=mn40r_airplane_ktemplates output_root="$OUT" progress=false print_summary=false \
    hydra.sweep.dir="$S" ${EXTRA:-}
fi
T=results/category/paper; mkdir -p "$T"
for fmt in md csv; do
  .venv/bin/python experiments/_lib/category_table.py --force "$S" --category airplane --choices cross,cross_top,score,density,agreement --format $fmt \
    --out "$T/templates_airplane.$fmt" --title "Airplane, K templates (shared resampled airplanes; 11 x 2 test views)"
done
