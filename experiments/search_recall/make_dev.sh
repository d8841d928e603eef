#!/usr/bin/env bash
# Ours' search on the clutter dev scenes 0-99 (uniform resting poses; configs/split/clutter.yaml `dev`,
# configs/split/clutter_objects.yaml `dev_A` / `dev_B`): each variant of the search over the same
# problems, loaded once -> results/search_recall/dev_variants.md (README.md). Needs
# ../shared/data/bop/ycbv/models (or $CATPOSE_SHARED_DATA). Environment: OUT (pickles and per-sample
# lines, default outputs/search_recall), PY, BENCH. Then the coarse search's ICP each way, and the selection's settings, on the embedded set's
# development seed 1 -> results/search_recall/embedded_dev.md, and the poor-fit fallback with category templates on
# that seed -> results/search_recall/embedded_dev_templates.md. Run from the repository root; ~1 h on two
# cores from nothing (each finished variant is kept and not run again).
# Issue 58 removed ours' options that were off by default (docs/choosing-defaults.md); the rows that set
# them, or a value that became a constant (grid_points, grid_template_points, grid_first_iterations,
# grid_keep), were dropped here: issue22, grid12_turns, grid12, grid12_prior, issue44_tpl512,
# issue44_escalate, yaw_beam32_first5, grid_keep12, sel_polish3, sel_polish2_small, sel_distinct*,
# fit_ratio*, and polish / distinct10 / ratio* of the embedded tables. Their lines in the results tables
# were written by this script at commit 9c64f33, which reruns them (`git checkout 9c64f33`). The count of
# half turns at the end (depth_final_turns) became a constant later: issue44_final3, sel_final_turns0,
# sel_final_turns3 and sel_final_refine3_turns3 went the same way (rerun them at 02fb724).
set -euo pipefail
PY=${PY:-.venv/bin/python}
OUT=${OUT:-outputs/search_recall}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
HERE=experiments/search_recall
eval "$($PY -m catpose.bench.run.environment portable)"
mkdir -p "$OUT"
[ -f "$OUT/dev.pkl" ] || $PY $HERE/problems.py "$OUT/dev.pkl" dataset=clutter "dataset.root=$SHARED/bop/ycbv" \
  "dataset.scenes=[$(seq -s, 0 99)]"
ISSUE44="resting.grid_icp=\"full\" resting.grid_beam=16"  # the coarse search as issue 44 first landed it
YAW="resting.grid_icp=\"yaw\""
# the selection before depth_tau / depth_free_weight were chosen (below): every row measured then pins it
TAU01="selection.depth_tau=0.1"
FREE1="selection.depth_free_weight=1.0"
# the poor-fit test on the whole mask at 0.9 (before depth_fit_erode_px 3 / depth_min_inliers 0.95 were chosen)
E0="selection.depth_fit_erode_px=0 selection.depth_min_inliers=0.9"
OLD="$TAU01 $FREE1 $E0"
# one placement for an up along the symmetry axis (before resting.grid_shift 0.5 was chosen): every row
# measured before it pins it (added to each row of V below but the shift rows and default)
S0="resting.grid_shift=0.0"
declare -A V=(
  [grid12_beam24]="$OLD resting.grid_icp=\"full\" resting.grid_yaws=12 resting.grid_beam=24"
  [issue44]="$OLD $ISSUE44"
  [yaw_beam16]="$OLD $YAW resting.grid_beam=16"
  [yaw_beam24]="$OLD $YAW resting.grid_beam=24"
  [yaw_beam32]="$OLD $YAW"
  [yaw_grid12_beam24]="$OLD $YAW resting.grid_yaws=12 resting.grid_beam=24"
  [union]="$OLD"  # issue 44's coarse search as landed (grid_icp union, beam 32), the selection before
  # the selection around its defaults, after issue 44's coarse search
  [sel_final_pixels300]="$OLD selection.depth_final_pixels=300"
  [sel_top_k8]="$OLD selection.depth_top_k=8"
  [sel_tau0125]="$E0 $FREE1 selection.depth_tau=0.125"
  [sel_tau015]="$E0 $FREE1 selection.depth_tau=0.15"
  [sel_tau02]="$E0 $FREE1 selection.depth_tau=0.2"
  [sel_free2]="$E0 $TAU01 selection.depth_free_weight=2.0"
  [sel_free2_tau015]="$E0 selection.depth_free_weight=2.0 selection.depth_tau=0.15"  # the choice then (README.md)
  # around the tolerance's defaults
  [sel_final_refine3]="$E0 selection.depth_final_refine=3"
  # the poor-fit test on the whole mask, or no fallback at all
  [whole_mask]="$E0"  # the defaults before the poor-fit test counted the mask's inner pixels
  [no_fallback]="selection.depth_min_inliers=0.0"
  # the poor-fit test on the mask's pixels 2 / 3 / 4 / 6 px inside its edge, below 0.9 / 0.95 / 0.98
  [inner3_t90]="selection.depth_fit_erode_px=3 selection.depth_min_inliers=0.9"
  [inner6_t90]="selection.depth_fit_erode_px=6 selection.depth_min_inliers=0.9"
  [inner3_t98]="selection.depth_fit_erode_px=3 selection.depth_min_inliers=0.98"
  [inner2_t98]="selection.depth_fit_erode_px=2 selection.depth_min_inliers=0.98"
  [inner4_t98]="selection.depth_fit_erode_px=4 selection.depth_min_inliers=0.98"
  [default]=""  # today's defaults (3 px inside, 0.95)
  # the last comparisons on a finer lattice: 4800 / 7200 / 9600 / 19200 mask pixels (default 2400)
  [final_pixels4800]="selection.depth_final_pixels=4800"
  [final_pixels7200]="selection.depth_final_pixels=7200"
  [final_pixels9600]="selection.depth_final_pixels=9600"
  [final_pixels19200]="selection.depth_final_pixels=19200"
  # an up along the symmetry axis (one yaw) also placed 7 times moved along the ground by 0.3 / 0.5 / 0.7 /
  # 1.0 x the template's radius about it (resting.grid_shift; default 0.5 since)
  [no_shift]=""  # the defaults before it (S0 added below)
  [shift03]="resting.grid_shift=0.3"
  [shift05]="resting.grid_shift=0.5"
  [shift07]="resting.grid_shift=0.7"
  [shift10]="resting.grid_shift=1.0"
)
for v in "${!V[@]}"; do
  case $v in shift*|default) ;; *) V[$v]="${V[$v]} $S0" ;; esac
done
ORDER=(grid12_beam24 issue44
  yaw_beam16 yaw_beam24 yaw_beam32 yaw_grid12_beam24 union
  sel_final_pixels300 sel_top_k8 sel_tau0125 sel_tau015 sel_tau02 sel_free2 sel_free2_tau015
  sel_final_refine3 whole_mask no_fallback
  inner3_t90 inner6_t90 inner3_t98 inner2_t98 inner4_t98 final_pixels4800 final_pixels7200 final_pixels9600
  final_pixels19200 no_shift shift03 shift05 shift07 shift10 default)
variants() {  # $1: problems pickle, $2: folder of the per-sample lines, then the variants (rows of V)
  local pkl=$1 dir=$2 v; shift 2
  for v in "$@"; do  # resumes: a finished variant is not run again
    if [ ! -s "$dir/$v.jsonl" ]; then
      # shellcheck disable=SC2086  # the settings are words
      $PY $HERE/variants.py "$dir/$v.jsonl.tmp" "$pkl" ${V[$v]}
      mv "$dir/$v.jsonl.tmp" "$dir/$v.jsonl"
    fi
  done
}
variants "$OUT/dev.pkl" "$OUT" "${ORDER[@]}"
$PY $HERE/table.py --out results/search_recall/dev_variants.md $(for v in "${ORDER[@]}"; do echo "$v=$OUT/$v.jsonl"; done)
# More development scenes (200-399; configs/split/clutter_objects_dev2.yaml): the choices since they were drawn
# (no fallback, the inner poor-fit test, the shifted placements) on
# 635 more views
[ -f "$OUT/dev2.pkl" ] || $PY $HERE/problems.py "$OUT/dev2.pkl" dataset=clutter "dataset.root=$SHARED/bop/ycbv" \
  dataset.num_scenes=400 "dataset.scenes=[$(seq -s, 200 399)]"
ORDER2=(whole_mask no_fallback inner3_t90 inner6_t90 inner3_t98
  inner2_t98 inner4_t98 final_pixels4800 final_pixels7200 final_pixels9600 final_pixels19200 no_shift shift03 shift05
  shift07 shift10 default)  # rows of V
mkdir -p "$OUT/dev2"
variants "$OUT/dev2.pkl" "$OUT/dev2" "${ORDER2[@]}"
$PY $HERE/table.py --out results/search_recall/dev2_variants.md --split clutter_objects_dev2 \
  --title "Ours on more clutter dev scenes (200-399), uniform resting poses" \
  $(for v in "${ORDER2[@]}"; do echo "$v=$OUT/dev2/$v.jsonl"; done)
# The embedded set's development seed (1), own model: the coarse search's ICP, each way; the selection's
# settings; the defaults before grid_shift (no_shift) and today's (default)
EMB="$OUT/embedded_dev"
ROWS=("full:resting.grid_icp=full resting.grid_beam=16 $OLD" "yaw:resting.grid_icp=yaw $OLD" "union:resting.grid_icp=union $OLD"
  "top_k8:selection.depth_top_k=8 $OLD" "tau0125:selection.depth_tau=0.125 $FREE1 $E0"
  "tau015:selection.depth_tau=0.15 $FREE1 $E0" "tau02:selection.depth_tau=0.2 $FREE1 $E0"
  "free2:selection.depth_free_weight=2.0 $TAU01 $E0" "free2_tau015:selection.depth_free_weight=2.0 selection.depth_tau=0.15 $E0"
  "whole_mask:$E0"
  "no_fallback:selection.depth_min_inliers=0.0" "no_shift:")
for i in "${!ROWS[@]}"; do ROWS[i]="${ROWS[i]} $S0"; done  # each measured before grid_shift was chosen
ROWS+=("default:")  # today's defaults (grid_shift 0.5)
bench_row() {  # $1: protocol, $2: seed, $3: output folder, $4: label prefix, $5: NAME:SETTINGS -> LABELS, DIRS
  local protocol=$1 seed=$2 dir=$3 prefix=$4 row=$5 kv s
  local name=${row%%:*}; set --
  for kv in ${row#*:}; do set -- "$@" "method.$kv"; done
  "${BENCH:-.venv/bin/bench}" run method=ours dataset=synthetic protocol=$protocol seed=$seed output_root="$dir" \
    progress=false print_summary=false "$@"
  s=${row#*:}  # a label holds no "=" (bench table splits RUN_DIR=LABEL at the last one)
  LABELS+=(--label "$(dirname "$(find "$dir" -name samples.jsonl | head -1)")=$prefix$name${s:+: ${s//=/ }}")
  DIRS+=("$dir")
}
LABELS=() DIRS=()
for row in "${ROWS[@]}"; do bench_row gt_model 1 "$EMB/${row%%:*}" "" "$row"; done
"${BENCH:-.venv/bin/bench}" table --force "${DIRS[@]}" "${LABELS[@]}" --layout generic --categories all \
  --metrics n,mean,median,acc10,acc30 --title "Ours on the embedded set, development seed 1, own model: the coarse search's ICP; the selection's settings" \
  --out results/search_recall/embedded_dev.md
# The category templates (protocol templates) on the development seeds 1-3: the poor-fit test on the whole
# mask (the fallback's answer always taken, declined over 1.25 / 1.5 / 2 x the winner's depth cost), none,
# the test 3 px inside the mask's edge below 0.9 / 0.98, and the defaults before grid_shift (3 px, 0.95;
# no_shift) and today's (default)
TPL="$OUT/embedded_dev_templates"
LABELS=() DIRS=()
IN="inner3_t90:selection.depth_fit_erode_px=3 selection.depth_min_inliers=0.9"
IN98="inner3_t98:selection.depth_fit_erode_px=3 selection.depth_min_inliers=0.98"
for sd in 1 2 3; do
  rows=("whole_mask:$E0" "$IN" "$IN98" "no_shift:")
  [ "$sd" = 1 ] && rows=("whole_mask:$E0" "no_fallback:selection.depth_min_inliers=0.0" "$IN" "$IN98" "no_shift:")
  for i in "${!rows[@]}"; do rows[i]="${rows[i]} $S0"; done  # each measured before grid_shift was chosen
  rows+=("default:")  # today's defaults (grid_shift 0.5)
  for row in "${rows[@]}"; do bench_row templates "$sd" "$TPL/${row%%:*}-seed$sd" "seed $sd, " "$row"; done
done
"${BENCH:-.venv/bin/bench}" table --force "${DIRS[@]}" "${LABELS[@]}" --layout generic --categories all \
  --metrics n,mean,median,acc10,acc30 --title "Ours on the embedded set, development seeds 1-3, category templates: the poor-fit fallback" \
  --out results/search_recall/embedded_dev_templates.md
