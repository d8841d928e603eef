#!/usr/bin/env bash
# Ours per object and resting pose, seeds 0-2, on one pair of parts: dev (the clutter dev scenes 0-99 with
# segmenter-like masks, dataset.mask_noise=1, and the shared YCB-V frames of scene 1) or report (clutter
# scenes 100-199, dirty masks, and YCB-V scene 2); one JSON line per sample (rest_recall.py) into
# outputs/rest_recall/LABEL/ (finished samples are kept), then the table results/rest_recall/PART_LABEL.md.
# Usage (repository root): bash experiments/rest_recall/make.sh PART LABEL [OVERRIDE ...] (overrides of ours)
set -euo pipefail
PART=${1:?usage: make.sh dev|report LABEL [OVERRIDE ...]}
LABEL=${2:?usage: make.sh dev|report LABEL [OVERRIDE ...]}
shift 2
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
OUT=outputs/rest_recall/$LABEL
case $PART in
  dev) scenes=$(seq -s, 0 99); ycbv=1 ;;
  report) scenes=$(seq -s, 100 199); ycbv=2 ;;
  *) echo "PART is dev or report" >&2; exit 2 ;;
esac
for seed in ${SEEDS:-0 1 2}; do
  nice -n 5 $PY experiments/rest_recall/rest_recall.py "$OUT/clutter_$PART-seed$seed.jsonl" "$seed" dataset=clutter \
    "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$scenes]" dataset.mask_noise=1.0 "$@"
  nice -n 5 $PY experiments/rest_recall/rest_recall.py "$OUT/ycbv_$PART-seed$seed.jsonl" "$seed" dataset=ycbv \
    "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$ycbv]" "$@" 2>/dev/null
done
mkdir -p results/rest_recall
$PY experiments/rest_recall/table.py "results/rest_recall/${PART}_$LABEL.md" "$LABEL" \
  "clutter $PART (dirty masks)=$OUT/clutter_$PART-seed*.jsonl" "YCB-V scene $ycbv=$OUT/ycbv_$PART-seed*.jsonl"
# TYO-L's one frame (basket, obj 19) under seeds 0-4, as dataset=bop and dataset=tyol: one line per run
if [ "$PART" = report ]; then
  for ds in bop tyol; do
    for seed in 0 1 2 3 4; do
      nice -n 5 $PY experiments/rest_recall/rest_recall.py "$OUT/tyol_$ds-seed$seed.jsonl" "$seed" dataset=$ds \
        "dataset.root=$SHARED/bop/tyol" "$@" 2>/dev/null >/dev/null
    done
  done
  $PY experiments/rest_recall/tyol.py "results/rest_recall/tyol_$LABEL.md" "$OUT"
fi
