#!/usr/bin/env bash
# K = 1, 3, 5 category templates on any modelnet40_normal_resampled root: the K-medoids of the
# root's aligned instances (`bench templates`), every instance that is a template for no K as test
# views (2 views each), each view registered to each template, then `experiments/_lib/category_table.py` (chosen /
# oracle / random, rules cross (the run's), score, density, agreement). Nothing is downloaded: give a root you have.
# Usage (repository root):
#   bash experiments/category_tables/make_any_root_ktemplates.sh ROOT ALIGNMENT_CSV CATEGORY OUT.md
#   (ROWS="ours icp" for more methods; default ours; TITLE="..." for the table's title, default the
#   category and ROOT; OUT gets OUT.csv beside it)
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
ROOT=${1:?root}; TABLE=${2:?alignment table}; CAT=${3:?category}; MD=${4:?output .md}
B=.venv/bin/bench
OUT=${OUT:-outputs/category/any_root}
W="$OUT/templates"
D=(dataset=modelnet40_resampled dataset.root="$ROOT" dataset.alignment_table="$TABLE" "dataset.categories=[$CAT]")
for K in 1 3 5; do
  # the dataset config's own templates need not be in ROOT: the medoids are chosen among ROOT's instances
  [ -f "$W/k$K/templates/any.yaml" ] || "$B" templates "${D[@]}" "dataset.templates.$CAT=[]" --category "$CAT" --k $K \
    --out "$W/k$K/templates/any.yaml"
done
union=$(.venv/bin/python -c "import sys, yaml; print(','.join(sorted({i for p in sys.argv[2:] for i in yaml.safe_load(open(p))[sys.argv[1]]})))" \
  "$CAT" "$W"/k{1,3,5}/templates/any.yaml)
rows=$(echo ${ROWS:-ours} | tr ' ' ',')
for K in 1 3 5; do
  "$B" run -m "+row=$rows" "${D[@]}" protocol=templates choice=cross protocol.exclude_templates=true "protocol.exclude_instances=[$union]" \
    +templates=any "hydra.searchpath=[file://$(cd "$W/k$K" && pwd)]" output_root="$OUT" progress=false print_summary=false \
    hydra.sweep.dir="$OUT/multirun/k$K"
done
for fmt in md csv; do
  .venv/bin/python experiments/_lib/category_table.py --force "$OUT/multirun/k1" "$OUT/multirun/k3" "$OUT/multirun/k5" --category "$CAT" --choices cross,cross_top,cross_top_turns,score,density,agreement \
    --format $fmt --out "${MD%.md}.$fmt" --title "${TITLE:-$CAT, K templates ($ROOT)}"
done
