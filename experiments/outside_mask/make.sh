#!/usr/bin/env bash
# Ours with the observed depth just outside the mask (run.py's variants) against ours' default, on the dev
# parts only: the clutter dev scenes 0-49 and YCB-V scene 1, segmenter-like masks (dataset.mask_noise=1;
# YCB-V scene 1 also with its written masks), seeds 0-2, every variant on each problem back to back, into
# outputs/outside_mask/<source>-seed<seed>/<variant>.jsonl (finished samples are kept), then the table
# results/outside_mask/dev.md (table.py).
# Usage (repository root): bash experiments/outside_mask/make.sh
#   PARTS="clutter0 clutter1" runs only those (clutter0-2, ycbv1dirty, ycbv1clean, timing, cleanclutter0-2);
#   NO_TABLE=1 skips the table. cleanclutter0-2: the clutter dev scenes with their written masks, the variants
#   of CLEAN_VARIANTS only.
# timing: every variant back to back on the clutter dev scenes 0-9 and YCB-V scene 1 (seed 0), one process
# alone (run it when nothing else of this study runs): the table's seconds.
set -euo pipefail
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
OUT=outputs/outside_mask
VARIANTS=${VARIANTS:-default,ring 3 px,ring 5 px,ring 3 px +refine,refine ring 3 px,ring 3 px W 0.5 +refine,ring 3 px final only +refine}
CLUTTER=(dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]" dataset.mask_noise=1.0)
CLEAN_VARIANTS=${CLEAN_VARIANTS:-default,ring 3 px,ring 3 px +refine,refine ring 3 px}
YCBV=(dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]")
for group in ${PARTS:-clutter0 clutter1 clutter2 ycbv1dirty ycbv1clean timing cleanclutter0 cleanclutter1 cleanclutter2}; do
  case $group in
    clutter[0-2]) nice -n 5 $PY experiments/outside_mask/run.py "$OUT/clutter-seed${group#clutter}" "${group#clutter}" "$VARIANTS" "${CLUTTER[@]}" 2>/dev/null ;;
    ycbv1dirty|ycbv1clean)
      noise=1.0; [ $group = ycbv1clean ] && noise=0.0
      for seed in 0 1 2; do
        nice -n 5 $PY experiments/outside_mask/run.py "$OUT/$group-seed$seed" "$seed" "$VARIANTS" "${YCBV[@]}" "dataset.mask_noise=$noise" 2>/dev/null
      done ;;
    cleanclutter[0-2])
      nice -n 5 $PY experiments/outside_mask/run.py "$OUT/clutterclean-seed${group#cleanclutter}" "${group#cleanclutter}" \
        "$CLEAN_VARIANTS" "${CLUTTER[@]:0:3}" dataset.mask_noise=0.0 2>/dev/null ;;
    timing)
      nice -n 5 $PY experiments/outside_mask/run.py "$OUT/timing-clutter-seed0" 0 "$VARIANTS" "${CLUTTER[@]:0:2}" \
        "dataset.scenes=[$(seq -s, 0 9)]" dataset.mask_noise=1.0 2>/dev/null
      nice -n 5 $PY experiments/outside_mask/run.py "$OUT/timing-ycbv1clean-seed0" 0 "$VARIANTS" "${YCBV[@]}" 2>/dev/null ;;
    *) echo "make.sh: unknown group $group (clutter0-2, ycbv1dirty, ycbv1clean, timing, cleanclutter0-2)" >&2; exit 2 ;;
  esac
done
if [ -z "${NO_TABLE:-}" ]; then
  mkdir -p results/outside_mask
  $PY experiments/outside_mask/table.py "$OUT" results/outside_mask/dev.md
fi
