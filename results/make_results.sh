#!/usr/bin/env bash
# Every table and figure the README and docs/ quote, regenerated into results/ (or $RESULTS):
#
#   bash results/make_results.sh [SECTION ...]      (repository root, after `make setup`; `make results`
#                                                    runs this, then copies the new figures into the docs)
#
# Sections (default: all of them, in this order; each resumes where it stopped: finished samples
# are skipped):
#   synthetic  the paper's tables on the embedded synthetic set (seed 0): one sweep per table
#              (configs/experiment/<table>.yaml) under three code paths of the numerical libraries,
#              results/tables/*.{md,tex,csv}, the report results/report/, and ours and the baselines
#              with the Kinect sensor model (results/tables/synthetic_kinect.md). ~1-1.5 h on 2 cores.
#   tables     the synthetic section's tables and report from its existing sweeps (no runs)
#   category   the paper's category tables on the shared ModelNet40 resampled shapes (the aligned
#              airplanes and chairs), every method (experiments/category_tables/make_*.sh: one template airplane,
#              K = 1, 3, 5 templates of airplanes and chairs with chosen / oracle / random template,
#              relative pose, ours' selection breadth top_k 3 and 18): results/category/paper/; the development tables that chose the cross
#              template choice (experiments/category_choice/ -> results/category/dev/) and the protocol's default
#              choice pooled over them (default_choice.md); the alignment estimates against the verified
#              tables (experiments/alignment/make_estimates.sh). ~1 h.
#   clutter    every method on the report scenes of the cluttered synthetic set of the real YCB-V
#              meshes, and ours before / after with ICP on the dev scenes that chose ours' defaults
#              (experiments/real_defaults/make_clutter.sh: results/clutter/). ~1 h.
#   real       ours, ICP, FGR and PPF under seeds 0-2 on the shared real data, YCB-V also with category templates
#              and as relative pairs (results/real/headline.md, the README's); every method, seed 0
#              (bench suite real: results/real/table.md, a column
#              per YCB-V scene as configs/split/ycbv.yaml names them, per-object tables in
#              results/real/objects.md), BOP
#              metrics of ICP, PPF and ours on the YCB-V frames (results/real/bop_ycbv.md), the sensor
#              model beside the real frames (results/real/sensor_stats.md). ~1 h.
#   ambiguity  why ours' wrong estimates won, search miss or ambiguous to its depth check, from the runs
#              of the synthetic, clutter and real sections (experiments/ambiguity/make_ambiguity.sh:
#              results/ambiguity/), ~2 min; and how often the truth is ours' answer or its runner-up,
#              from runs of its own (experiments/runner_up/make_runner_up.sh: results/runner_up/), ~5 min.
#   perf       seconds per registration (bench perf) on synthetic, YCB-V and ModelNet40 problems, and
#              the speed tables made from those CSVs and the GPU check's (experiments/speed/make_speed.sh:
#              results/perf/*.md). Run it on an otherwise idle machine: it measures wall time.
#   api        catpose.register without `up` (experiments/api_without_up/make_without_up.sh, when present; ~1.5 h)
#              and with a depth frame beside bench run (experiments/api_frames/make_frames.sh; ~1 min).
#   figures    a figure of each table the README quotes, from the committed tables alone
#              (python tools/table_figure.py: @10 and @30 per method, the mean error
#              beside): results/figures/*.{png,pdf,csv}. Seconds.
# The sections that need the shared data (../shared/data or $CATPOSE_SHARED_DATA) skip with a note
# when it is absent.
#
# Environment: OUT (run directories, default outputs/results), RESULTS (where the tables go,
# default results; point it at an empty folder to regenerate everything beside the committed
# files), LAUNCHER (e.g. hydra/launcher=local_procs with the cluster extra, `make cluster`).
#
# Numbers that hold on any CPU: the synthetic tables are computed under the portable numeric profile
# (catpose.bench.run.environment.portable_profile: OpenBLAS's Haswell kernel, NumPy without its AVX-512
# loops, torch's AVX2 kernels, numba compiling for Haswell), which every x86-64 CPU with AVX2 runs,
# AVX-512 ones included, so they come out the same there. The experiments then run again under other
# code paths (OpenBLAS Sandybridge with torch's default kernels; where the CPU has AVX-512, its own
# AVX-512 paths), each into its own output root, and the Markdown tables' notes say per row how many
# views changed and the range of the overall figures (experiments/stability): a difference between
# methods smaller than that range is chaos of ambiguous views, not evidence.
set -euo pipefail
cd "$(dirname "$0")/.."
B=.venv/bin/bench
PY=.venv/bin/python
OUT=${OUT:-outputs/results}
RESULTS=${RESULTS:-results}
S=$OUT/multirun  # named sweep directories, so a re-run resumes into the same ones
V=$OUT-variants  # the same sweeps under other code paths
EXPERIMENTS=(optimiser ablation one_template templates relative_real tyol)
SHARED=$("$PY" -c 'from catpose.bench.run.config import shared_data_dir; print(shared_data_dir())')
SECTIONS=("$@")
[ ${#SECTIONS[@]} -gt 0 ] || SECTIONS=(synthetic category clutter real ambiguity perf api figures)
eval "$("$PY" -m catpose.bench.run.environment portable)"
source experiments/default_runs.sh

run_experiments() {  # $1: output root
  for e in "${EXPERIMENTS[@]}"; do
    "$B" run -m +experiment=$e dataset=synthetic seed=0 output_root="$1" progress=false print_summary=false \
      hydra.sweep.dir="$1/multirun/$e" ${LAUNCHER:-}
  done
}

synthetic_runs() {
  run_experiments "$OUT"
  (export OPENBLAS_CORETYPE=Sandybridge ATEN_CPU_CAPABILITY=default; run_experiments "$V/sandybridge-torch-default")
  if grep -qw avx512f /proc/cpuinfo 2>/dev/null; then
    (unset NPY_DISABLE_CPU_FEATURES NUMBA_CPU_NAME MKL_ENABLE_INSTRUCTIONS
     export OPENBLAS_CORETYPE=SkylakeX ATEN_CPU_CAPABILITY=avx512; run_experiments "$V/avx512")
  fi
  # the embedded set with the Kinect sensor model (physical sizes, depth noise, flying pixels, bleed)
  "$B" run -m method=ours,icp dataset=synthetic dataset.sensor=kinect dataset.instances_per_category=1 seed=0 \
    output_root="$OUT/kinect" progress=false print_summary=false hydra.sweep.dir="$OUT/kinect/multirun" ${LAUNCHER:-}
  for m in fgr ransac teaser; do  # one at a time: a sweep composes the default method first, which has no matching key
    for matching in direct dictionary; do
      "$B" run method=$m method.matching=$matching dataset=synthetic dataset.sensor=kinect \
        dataset.instances_per_category=1 seed=0 output_root="$OUT/kinect" progress=false print_summary=false
    done
  done
  "$B" run method=ppf dataset=synthetic dataset.sensor=kinect dataset.instances_per_category=1 seed=0 \
    output_root="$OUT/kinect" progress=false print_summary=false
}

synthetic_tables() {
  local STAB=() T="$RESULTS/tables" G="$OUT/synthetic-gt_model" P="$OUT/synthetic-templates"
  for root in "$V"/*/; do [ -d "$root" ] && STAB+=(--stability "${root%/}"); done
  mkdir -p "$T"
  rm -f "$T"/*.md "$T"/*.tex "$T"/*.csv  # only what this section writes is left
  for fmt in md latex csv; do
    ext=$fmt; [ "$fmt" = latex ] && ext=tex
    # the stability notes are Markdown text: bench table's table with them under it
    ST=(); TB=("$B" table); if [ "$fmt" = md ]; then ST=(${STAB[@]+"${STAB[@]}"}); TB=("$PY" experiments/stability/stability.py); fi
    for e in optimiser ablation one_template templates tyol; do
      "${TB[@]}" --force --sweep "$S/$e" --format $fmt ${ST[@]+"${ST[@]}"} --out "$T/$e.$ext"
    done
    "${TB[@]}" --force --sweep "$S/optimiser" --layout generic --format $fmt ${ST[@]+"${ST[@]}"} --out "$T/gt_model_all.$ext"
    "${TB[@]}" --force --sweep "$S/templates" --layout generic --format $fmt --error err_deg ${ST[@]+"${ST[@]}"} \
      --title "Category templates (3 other instances; estimate kept by the protocol's choice, fused)" --out "$T/templates_selected.$ext"
    "${TB[@]}" --force --sweep "$S/templates" --layout generic --format $fmt --error oracle_err_deg ${ST[@]+"${ST[@]}"} \
      --title "Category templates: minimum error across templates (oracle, the paper's Table templatechair)" --out "$T/templates_oracle.$ext"
    "${TB[@]}" --force --sweep "$S/relative_real" --layout generic --format $fmt ${ST[@]+"${ST[@]}"} \
      --title "Relative pose between two views of one object, each registered to the category templates" --out "$T/relative.$ext"
    "$B" table --force "$OUT/kinect/synthetic-gt_model" --layout generic --categories all --format $fmt \
      --metrics mean,median,acc5,acc10,acc30,5deg5cm,10deg10cm,auc30,trans \
      --title "Embedded set with the Kinect sensor model (8 categories x 1 instance x 2 views, seed 0)" --out "$T/synthetic_kinect.$ext"
  done
  # the report: every category, ours beside ICP and the three dictionary-matching baselines (own
  # model), and ours beside ICP with 3 category templates
  local runs=() labels=()
  add() {  # $1: run directory glob, $2: label
    local d; d=$(ls -dt $1 2>/dev/null | head -1)
    [ -n "$d" ] || { echo "make_results: no run directory $1; run the synthetic section first" >&2; exit 2; }
    runs+=("$d"); labels+=(--label "$d=$2")
  }
  add "$G/icp/seed0-+row=icp-*" "ICP"
  add "$G/fgr/seed0-+row=fgr_dictionary_fpfh-*" "FGR (dictionary FPFH)"
  add "$G/teaser/seed0-+row=teaser_dictionary_lps-*" "TEASER (dictionary LPS)"
  add "$G/ransac/seed0-+row=ransac_dictionary_fpfh-*" "RANSAC (dictionary FPFH)"
  add "$G/ppf/seed0-+row=ppf-*" "PPF"
  add "$G/ours/seed0-+row=ours-*" "Ours"
  add "$P/icp/seed0-+row=icp,protocol.max_templates=null-*" "ICP"
  add "$P/ours/seed0-+row=ours,protocol.max_templates=null-*" "Ours"
  "$B" report --force "${runs[@]}" "${labels[@]}" --out "$RESULTS/report" \
    --note "Made by results/make_results.sh (synthetic section): the embedded synthetic set, seed 0, 8 categories x 3 instances x 2 views; templates: 3 other instances of the category."
}

category() {
  if [ ! -d "$SHARED/modelnet40_normal_resampled" ]; then
    echo "make_results: category skipped: no $SHARED/modelnet40_normal_resampled" >&2; return 0
  fi
  local C="$OUT/category"
  for script in make_one_template_airplane make_templates_airplane make_templates_chair make_relative; do
    OUT="$C" bash experiments/category_tables/$script.sh
  done
  OUT="$C" bash experiments/selection_breadth/make_selection_report.sh
  for script in make_chair_dev make_embedded_choice; do  # the template choice's development tables
    OUT="$C" bash experiments/category_choice/$script.sh
  done
  local D=results/category/dev  # the protocol's default choice, pooled over them (and the procedural chairs')
  "$PY" experiments/category_choice/default_choice.py $D/embedded_seed{1,2,3}_k3.csv $D/chair_dev_k3.csv \
    $D/chair_dev_swaps.csv $D/chair_procedural_k3.csv --out $D/default_choice.md
  bash experiments/alignment/make_estimates.sh
}

real() {
  if [ ! -d "$SHARED" ]; then echo "make_results: real skipped: no shared data at $SHARED" >&2; return 0; fi
  local R="$OUT/real"
  mkdir -p "$RESULTS/real"
  # the README's real table (results/real/headline.md): the whole sets under seeds 0, 1, 2 (a cell: their
  # mean [min-max]), YCB-V also with category templates and as relative pairs (the paper's protocols),
  # the methods cheap enough for three seeds of every protocol, PPF (OpenCV's) beside them, and how often
  # each cell's answers agree across the seeds (~30 CPU-min)
  nice "$B" suite real --force --output-root "$R" --sets ycbv,ycbv_templates,ycbv_relative,tyol,modelnet40_resampled \
    --methods ours,icp,fgr,ppf --headline "$RESULTS/real/headline.md"
  # every method, seed 0, a column per YCB-V scene (results/real/table.md) and per object (objects.md)
  nice "$B" suite real --force --output-root "$R" --sets ycbv,tyol,modelnet40_resampled,redwood --seeds 0 \
    --write "$RESULTS/real/table.md" --objects "$RESULTS/real/objects.md"
  if [ -d "$SHARED/bop/ycbv" ]; then  # BOP's metrics of ICP, PPF and ours on the YCB-V frames
    local scored=()
    for m in icp ppf ours; do
      run=$(default_runs "$R/ycbv-gt_model/$m" | grep '/seed0-' | head -1)  # the default run of seed 0, not ours-visibility's
      [ -n "$run" ] || { echo "make_results: no default run of $m in $R/ycbv-gt_model" >&2; exit 2; }
      rm -rf "$R/bop/$m" "$R/bop/${m}_ycbv-test.csv"*; mkdir -p "$R/bop"
      "$B" export --force "$run" --out "$R/bop/${m}_ycbv-test.csv"
      "$B" score --force "$R/bop/${m}_ycbv-test.csv" --gt "$run" --out "$R/bop/$m" > /dev/null
      scored+=("$R/bop/$m")
    done
    "$B" table --force "${scored[@]}" --bop-metrics ar_mssd,ar_mspd,ar_vsd,adds@0.1,5deg5cm,10deg10cm --by object,category \
      --out "$RESULTS/real/bop_ycbv.md"
  fi
  "$PY" experiments/_lib/sensor_stats.py > "$RESULTS/real/sensor_stats.md"
}

figures() {  # one per table the README quotes: table|figure stem|title
  local F="$RESULTS/figures"
  mkdir -p "$F"
  while IFS='|' read -r table stem title; do
    [ -f "$RESULTS/$table" ] || { echo "make_results: figures: no $RESULTS/$table; skipped" >&2; continue; }
    "$PY" tools/table_figure.py "$RESULTS/$table" --out "$F/$stem" --title "$title" > /dev/null
  done <<'TABLES'
report/tables/gt_model_summary.md|embedded_gt_model|Embedded synthetic set, each view against its own model (48 views, seed 0)
real/headline.md|real|Real frames (YCB-Video, TYO-L), ModelNet40 resampled shapes; YCB-V with templates, relative (seeds 0-2)
clutter/headline.md|clutter|Cluttered synthetic scenes of the YCB-Video objects (report scenes)
category/paper/one_template_airplane.md|one_template_airplane|ModelNet40 airplanes, another instance as the only template
TABLES
}

for section in "${SECTIONS[@]}"; do
  case $section in
    synthetic) synthetic_runs; synthetic_tables ;;
    tables) synthetic_tables ;;
    category) category ;;
    clutter) if [ -d "$SHARED/bop/ycbv/models" ]; then RUNS="$OUT/clutter" RESULTS="$RESULTS" bash experiments/real_defaults/make_clutter.sh
             else echo "make_results: clutter skipped: no $SHARED/bop/ycbv/models" >&2; fi ;;
    real) real ;;
    ambiguity) if [ -d "$SHARED/bop/ycbv/models" ]; then OUT="$OUT" RESULTS="$RESULTS" bash experiments/ambiguity/make_ambiguity.sh
                 RUNS="$OUT/runner_up" RESULTS="$RESULTS" bash experiments/runner_up/make_runner_up.sh
               else echo "make_results: ambiguity skipped: no $SHARED/bop/ycbv/models" >&2; fi ;;
    perf) RESULTS="$RESULTS" bash experiments/speed/make_speed.sh ;;
    api) if [ -f experiments/api_without_up/make_without_up.sh ]; then bash experiments/api_without_up/make_without_up.sh; fi
         bash experiments/api_frames/make_frames.sh ;;
    figures) figures ;;
    *) echo "make_results: unknown section '$section'; use synthetic, tables, category, clutter, real, ambiguity, perf, api, figures" >&2; exit 2 ;;
  esac
done
