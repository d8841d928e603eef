#!/usr/bin/env bash
# Ours and PPF on the development parts only, seeds 0-2 (finished runs are kept): the clutter dev scenes
# 0-14 and, as a second clutter source, 15-39 (configs/split/clutter.yaml `dev`) with segmenter-like
# masks (dataset.mask_noise=1, as experiments/mask_noise), and YCB-V scene 1 (configs/split/ycbv.yaml's
# choose part; never scene 2), into $OUT/<source>/<method>-seed<k>; then tiebreak.py writes
# results/ppf_tiebreak/dev.md. Needs ../shared/data/bop/ycbv (or $CATPOSE_SHARED_DATA) and the `ppf`
# extra. ~30 min on two cores. SOURCES (default "clutter ycbv1 clutter15") runs only those.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
OUT=${OUT:-outputs/ppf_tiebreak}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
eval "$($PY -m catpose.bench.run.environment portable)"
COMMON=(threads=1 progress=false print_summary=false)
for source in ${SOURCES:-clutter ycbv1 clutter15}; do
  case $source in
    clutter) data=(dataset=clutter "dataset.scenes=[$(seq -s, 0 14)]" dataset.mask_noise=1.0) ;;
    clutter15) data=(dataset=clutter "dataset.scenes=[$(seq -s, 15 39)]" dataset.mask_noise=1.0) ;;
    ycbv1) data=(dataset=ycbv "dataset.scenes=[1]") ;;
    *) echo "make_runs.sh: unknown source $source (clutter, clutter15, ycbv1)" >&2; exit 2 ;;
  esac
  for seed in 0 1 2; do
    for method in ours ppf; do
      nice "$BENCH" run method=$method "${data[@]}" "dataset.root=$SHARED/bop/ycbv" seed=$seed \
        output_root="$OUT/$source/$method-seed$seed" "${COMMON[@]}"
    done
  done
done
mkdir -p results/ppf_tiebreak
"$PY" experiments/ppf_tiebreak/tiebreak.py "$OUT" --out results/ppf_tiebreak/dev.md
