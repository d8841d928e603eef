#!/usr/bin/env bash
# The paper's ModelNet40 relative-pose table on the shared resampled train shapes: ours and every
# baseline (ICP; FGR, TEASER re-implementation and RANSAC with dictionary matching), each view
# registered to its own model (template_source=own, the paper's dagger rows) or to the category
# templates (template_source=category, the star rows; configs/experiment/mn40r_relative.yaml).
# Output: results/category/paper/relative.{md,csv}.
# Usage (repository root): bash experiments/category_tables/make_relative.sh [tables]
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
OUT=${OUT:-outputs/category}
S=$OUT/multirun/mn40r_relative
if [ "${1:-}" != tables ]; then
  "$B" run -m +experiment=mn40r_relative output_root="$OUT" progress=false print_summary=false \
    hydra.sweep.dir="$S" ${EXTRA:-}
fi
T=results/category/paper; mkdir -p "$T"
for fmt in md csv; do
  "$B" table --force --sweep "$S" --layout generic --categories airplane,chair --metrics mean,median,acc10,acc30,n,failed \
    --format $fmt --out "$T/relative.$fmt" \
    --title "Relative pose of two views (consecutive pairs, 17 airplanes and 2 chairs x 3 views)"
done
