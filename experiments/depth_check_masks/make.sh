#!/usr/bin/env bash
# Ours on the dev parts only (the clutter dev scenes 0-49 and YCB-V scene 1, never the report scenes), seeds
# 0-2, one JSON line per sample (rescore.py: ours' answer, found@10, and ours' held poses re-scored by the
# depth check's robust variants) into outputs/depth_check_masks/LABEL/ (finished samples are kept), then the
# table results/depth_check_masks/dev.md. Labels: dirty (dataset.mask_noise=1), clean (the written masks),
# dilate, erode, bleed (one component of the dirty masks alone, the same draws); MASKS-CHECK (dirty-edge2,
# clean-trim20, ...) runs ours with its depth check replaced by a variant for the whole run (rescore.py check:):
# edge2, edge4, mad2, mad3, trim10, trim20, trim30, grow3.
# Usage (repository root): bash experiments/depth_check_masks/make.sh   (LABELS="dirty clean" runs only those)
set -euo pipefail
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
for label in ${LABELS:-dirty clean dilate erode bleed dirty-edge2 dirty-edge4 dirty-mad2 dirty-trim20 dirty-grow3}; do
  noise=(dataset.mask_noise=1.0)
  masks=${label%%-*}
  case ${label#"$masks"} in
    "") ;;
    -edge2) noise+=("check:edge 2 px") ;;
    -edge4) noise+=("check:edge 4 px") ;;
    -mad2) noise+=("check:MAD band c=2") ;;
    -mad3) noise+=("check:MAD band c=3") ;;
    -trim10) noise+=("check:trimmed 10 %") ;;
    -trim20) noise+=("check:trimmed 20 %") ;;
    -trim30) noise+=("check:trimmed 30 %") ;;
    -grow3) noise+=("check:grown 3 px in MAD band c=3") ;;
    *) echo "make.sh: unknown check variant in $label" >&2; exit 2 ;;
  esac
  case $masks in
    dirty) ;;
    clean) noise=(dataset.mask_noise=0.0 "${noise[@]:1}") ;;
    dilate|erode|bleed) noise+=("noise:$masks") ;;
    *) echo "make.sh: unknown label $label (dirty, clean, dilate, erode, bleed)" >&2; exit 2 ;;
  esac
  for seed in 0 1 2; do
    nice -n 5 $PY experiments/depth_check_masks/rescore.py "outputs/depth_check_masks/$label/clutter-seed$seed.jsonl" \
      "$seed" dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]" "${noise[@]}" 2>/dev/null
    nice -n 5 $PY experiments/depth_check_masks/rescore.py "outputs/depth_check_masks/$label/ycbv1-seed$seed.jsonl" \
      "$seed" dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]" "${noise[@]}" 2>/dev/null
  done
done
if [ -z "${NO_TABLE:-}" ]; then
  mkdir -p results/depth_check_masks
  $PY experiments/depth_check_masks/table.py outputs/depth_check_masks results/depth_check_masks/dev.md
fi
