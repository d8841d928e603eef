#!/usr/bin/env bash
# Reproduces the committed tables in results/ on the embedded synthetic set (seed 0): one sweep per
# paper table (configs/experiment/<table>.yaml), then its tables from the sweep's files.
# Usage: bash results/make_results.sh [tables]   (repository root, after `make setup`; `tables`: only
# rebuild the tables and report from existing sweeps)
# Runs resume: re-running skips finished samples. Takes ~1-1.5 h on 2 CPU cores (the experiments run
# three times, see below); with the cluster extra (`make cluster`) add e.g.
# LAUNCHER=hydra/launcher=local_procs, or =slurm on a cluster.
#
# Numbers that hold on any CPU: the tables are computed under the portable numeric profile
# (catpose.bench.run.environment.portable_profile: OpenBLAS's Haswell kernel, NumPy without its AVX-512
# loops, torch's AVX2 kernels, numba compiling for Haswell), which every x86-64 CPU with AVX2 runs,
# AVX-512 ones included, so they come out the same there. The experiments then run again under other
# code paths (OpenBLAS Sandybridge with torch's default kernels; where the CPU has AVX-512, its own
# AVX-512 paths), each into its own output root, and the Markdown tables' notes say per row how many
# views changed and the range of the overall figures (catpose.bench.report.stability): a difference between
# methods smaller than that range is chaos of ambiguous views, not evidence.
set -euo pipefail
cd "$(dirname "$0")/.."
B=.venv/bin/bench
PY=.venv/bin/python
OUT=${OUT:-outputs/results}
S=$OUT/multirun  # named sweep directories, so a re-run resumes into the same ones
V=$OUT-variants  # the same sweeps under other code paths
EXPERIMENTS=(optimiser ablation one_template templates relative_real tyol)
eval "$("$PY" -m catpose.bench.run.environment portable)"

run_experiments() {  # $1: output root
  for e in "${EXPERIMENTS[@]}"; do
    "$B" run -m +experiment=$e dataset=synthetic seed=0 output_root="$1" progress=false print_summary=false \
      hydra.sweep.dir="$1/multirun/$e" ${LAUNCHER:-}
  done
}

if [ "${1:-}" != tables ]; then
  run_experiments "$OUT"
  (export OPENBLAS_CORETYPE=Sandybridge ATEN_CPU_CAPABILITY=default; run_experiments "$V/sandybridge-torch-default")
  if grep -qw avx512f /proc/cpuinfo 2>/dev/null; then
    (unset NPY_DISABLE_CPU_FEATURES NUMBA_CPU_NAME MKL_ENABLE_INSTRUCTIONS
     export OPENBLAS_CORETYPE=SkylakeX ATEN_CPU_CAPABILITY=avx512; run_experiments "$V/avx512")
  fi
fi
STAB=()
for root in "$V"/*/; do [ -d "$root" ] && STAB+=(--stability "${root%/}"); done

T=results/tables
mkdir -p "$T"
for fmt in md latex csv; do
  ext=$fmt; [ "$fmt" = latex ] && ext=tex
  ST=(); if [ "$fmt" = md ]; then ST=(${STAB[@]+"${STAB[@]}"}); fi  # the stability notes are Markdown text
  for e in optimiser ablation one_template templates tyol; do
    "$B" table --sweep "$S/$e" --format $fmt ${ST[@]+"${ST[@]}"} --out "$T/$e.$ext"
  done
  "$B" table --sweep "$S/optimiser" --layout generic --format $fmt ${ST[@]+"${ST[@]}"} --out "$T/gt_model_all.$ext"
  "$B" table --sweep "$S/templates" --layout generic --format $fmt --error err_deg ${ST[@]+"${ST[@]}"} \
    --title "Category templates (3 other instances; estimate chosen by the method's own score)" --out "$T/templates_selected.$ext"
  "$B" table --sweep "$S/templates" --layout generic --format $fmt --error oracle_err_deg ${ST[@]+"${ST[@]}"} \
    --title "Category templates: minimum error across templates (oracle, the paper's Table templatechair)" --out "$T/templates_oracle.$ext"
  "$B" table --sweep "$S/relative_real" --layout generic --format $fmt ${ST[@]+"${ST[@]}"} \
    --title "Relative pose between two views of one object, each registered to the category templates" --out "$T/relative.$ext"
done
G="$OUT/synthetic-gt_model"
"$B" report "$G/icp" "$G/ours" --label "$(ls -d "$G"/ours/seed0-+row=ours-*)=Ours" --out results/report --qualitative 1
