#!/usr/bin/env bash
# Issue 58's report condition, measured as stated: segmenter-like masks (dataset.mask_noise=1) on the
# clutter set's report scenes 100-199 and on the shared YCB-V frames, seeds 0-2, for ours and the two
# methods the issue compares it with (ICP, PPF), and the written masks beside them; ours also on the
# dev scenes 0-99 with segmenter-like masks, the object split's choose parts. `bench run` per method and
# seed into $OUT (finished runs resume), then results/dirty_report/report.md (table.py). Nothing is
# chosen here (README.md).
# Usage (repository root): bash experiments/dirty_report/make.sh      (~1 h on two cores)
set -euo pipefail
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
B=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
OUT=${OUT:-outputs/dirty_report}
eval "$($PY -m catpose.bench.run.environment portable)"
Q=(progress=false print_summary=false threads=1)
$B clutter
run() {  # NOISE METHOD SET SCENES: one method's runs, seeds 0-2, into $OUT/[written/]SET/METHOD
  local noise=$1 method=$2 set=$3 scenes=$4 root=$OUT
  [ "$noise" = 1.0 ] || root=$OUT/written
  for seed in 0 1 2; do
    if [ "$set" = ycbv ]; then
      $B run "${Q[@]}" dataset.mask_noise=$noise method=$method dataset=ycbv "dataset.root=$SHARED/bop/ycbv" \
        seed=$seed "output_root=$root/$set/$method" 2>/dev/null
    else
      $B run "${Q[@]}" dataset.mask_noise=$noise method=$method dataset=clutter "dataset.root=$SHARED/bop/ycbv" \
        "dataset.scenes=[$(seq -s, $scenes)]" seed=$seed "output_root=$root/$set/$method" 2>/dev/null
    fi
  done
}
# segmenter-like masks (the condition), then the written ones beside them; two queues, one per core
{ run 1.0 ours clutter_report "100 199"; run 1.0 ours clutter_dev "0 99"; run 1.0 ours ycbv ""; run 1.0 ppf ycbv ""
  run 1.0 ppf clutter_report "100 199"; run 0.0 ppf clutter_report "100 199"; } &
{ run 1.0 icp clutter_report "100 199"; run 1.0 icp ycbv ""
  for m in ours icp ppf; do run 0.0 $m ycbv ""; done; run 0.0 ours clutter_report "100 199"
  run 0.0 icp clutter_report "100 199"; } &
wait
$PY experiments/dirty_report/table.py "$OUT" results/dirty_report/report.md
