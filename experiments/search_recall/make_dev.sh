#!/usr/bin/env bash
# Ours' search on the clutter dev scenes 0-99 (uniform resting poses; configs/split/clutter.yaml `dev`,
# configs/split/clutter_objects.yaml `dev_A` / `dev_B`): each variant of the search over the same
# problems, loaded once -> results/search_recall/dev_variants.md (README.md). Needs
# ../shared/data/bop/ycbv/models (or $CATPOSE_SHARED_DATA). Environment: OUT (pickles and per-sample
# lines, default outputs/search_recall), PY. Run from the repository root; ~1 h on two cores.
set -euo pipefail
PY=${PY:-.venv/bin/python}
OUT=${OUT:-outputs/search_recall}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
HERE=experiments/search_recall
eval "$($PY -m catpose.bench.run.environment portable)"
mkdir -p "$OUT"
[ -f "$OUT/dev.pkl" ] || $PY $HERE/problems.py "$OUT/dev.pkl" dataset=clutter "dataset.root=$SHARED/bop/ycbv" \
  "dataset.scenes=[$(seq -s, 0 99)]"
BEFORE="resting.grid_yaws=0 resting.max_poses=5 resting.min_probability=0.05 resting.escalate_below=0.95 selection.depth_rest_prior=0.03 selection.depth_half_turns=true"
FULL="resting.grid_yaws=12 resting.grid_beam=0 resting.grid_points=256"
declare -A V=(
  [issue22]="$BEFORE"
  [grid12_turns]="$FULL selection.depth_half_turns=true"
  [grid12]="$FULL"
  [grid12_prior]="$FULL selection.depth_rest_prior=0.03"
  [grid12_beam24]="resting.grid_yaws=12 resting.grid_beam=24"
  [default]=""
  [default_tpl512]="resting.grid_template_points=512"
  [default_final3]="selection.depth_final_turns=3"
  [default_escalate]="resting.escalate_below=0.95"
)
ORDER=(issue22 grid12_turns grid12 grid12_prior grid12_beam24 default default_tpl512 default_final3 default_escalate)
for v in "${ORDER[@]}"; do  # resumes: a finished variant is not run again
  if [ ! -s "$OUT/$v.jsonl" ]; then
    # shellcheck disable=SC2086  # the settings are words
    $PY $HERE/variants.py "$OUT/$v.jsonl.tmp" "$OUT/dev.pkl" ${V[$v]}
    mv "$OUT/$v.jsonl.tmp" "$OUT/$v.jsonl"
  fi
done
$PY $HERE/table.py --out results/search_recall/dev_variants.md $(for v in "${ORDER[@]}"; do echo "$v=$OUT/$v.jsonl"; done)
