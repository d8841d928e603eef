#!/usr/bin/env bash
# Ours with its coarse search on seed-free points (run.py's variants) against ours' default, on the dev
# parts only: the clutter dev scenes 0-49 and YCB-V scene 1, each with the written masks
# (dataset.mask_noise=0) and with segmenter-like masks (dataset.mask_noise=1); seeds 0-2; every variant on
# each problem back to back, into outputs/seed_free/<source>-seed<seed>/<variant>.jsonl (finished samples are
# kept), then the table results/seed_free/dev.md (table.py).
# Usage (repository root): bash experiments/seed_free/make.sh
#   PARTS="cleanclutter0 ycbv1clean" runs only those (cleanclutter0-2, ycbv1clean, clutter0-2, ycbv1dirty);
#   VARIANTS="default,search on fixed points" runs only those; NO_TABLE=1 skips the table.
set -euo pipefail
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
OUT=${OUT:-outputs/seed_free}
VARIANTS=${VARIANTS:-default,search on fixed points,pool on fixed points,step 2 on fixed points}
CLUTTER=(dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]")
YCBV=(dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]")
for part in ${PARTS:-cleanclutter0 cleanclutter1 cleanclutter2 ycbv1clean clutter0 clutter1 clutter2 ycbv1dirty}; do
  case $part in
    cleanclutter[0-2]) nice -n 5 $PY experiments/seed_free/run.py "$OUT/clutterclean-seed${part#cleanclutter}" \
      "${part#cleanclutter}" "$VARIANTS" "${CLUTTER[@]}" dataset.mask_noise=0.0 2>/dev/null ;;
    clutter[0-2]) nice -n 5 $PY experiments/seed_free/run.py "$OUT/clutter-seed${part#clutter}" "${part#clutter}" \
      "$VARIANTS" "${CLUTTER[@]}" dataset.mask_noise=1.0 2>/dev/null ;;
    ycbv1dirty|ycbv1clean)
      noise=1.0; [ $part = ycbv1clean ] && noise=0.0
      for seed in 0 1 2; do
        nice -n 5 $PY experiments/seed_free/run.py "$OUT/$part-seed$seed" "$seed" "$VARIANTS" "${YCBV[@]}" \
          "dataset.mask_noise=$noise" 2>/dev/null
      done ;;
    *) echo "make.sh: unknown part $part (cleanclutter0-2, ycbv1clean, clutter0-2, ycbv1dirty)" >&2; exit 2 ;;
  esac
done
if [ -z "${NO_TABLE:-}" ]; then
  $PY experiments/seed_free/table.py "$OUT" results/seed_free/dev.md
fi
