#!/usr/bin/env bash
# experiments/robust_start (README.md): ours with the coarse search's start at the points' mean (default)
# and at their median, on the dev parts (clutter dev 0-49 and YCB-V scene 1, dirty and written masks;
# seeds 0-2) into outputs/robust_start/<source>-seed<seed>/<variant>.jsonl, and with the category
# templates on the embedded set (seeds 1-3) into outputs/robust_start/templates/; then the table
# results/robust_start/dev.md (table.py).
# Usage (repository root): bash experiments/robust_start/make.sh   (PARTS="clutter ycbv templates" by default)
set -euo pipefail
source experiments/_lib/seed_tables.sh
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
OUT=${OUT:-outputs/robust_start}
V="default,median start"
CLUTTER=(dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]")
YCBV=(dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]")
for part in ${PARTS:-clutter ycbv templates}; do
  for seed in 0 1 2; do
    case $part in
      clutter)
        nice -n 5 $PY experiments/robust_start/run.py "$OUT/clutter-seed$seed" $seed "$V" "${CLUTTER[@]}" dataset.mask_noise=1.0 2>/dev/null
        nice -n 5 $PY experiments/robust_start/run.py "$OUT/clutterclean-seed$seed" $seed "$V" "${CLUTTER[@]}" 2>/dev/null ;;
      ycbv)
        nice -n 5 $PY experiments/robust_start/run.py "$OUT/ycbv1dirty-seed$seed" $seed "$V" "${YCBV[@]}" dataset.mask_noise=1.0 2>/dev/null
        nice -n 5 $PY experiments/robust_start/run.py "$OUT/ycbv1clean-seed$seed" $seed "$V" "${YCBV[@]}" 2>/dev/null ;;
      templates)
        for v in default median; do
          name=$v; [ $v = median ] && name="median start"
          nice -n 5 $PY experiments/robust_start/run.py --bench "$name" run method=ours dataset=synthetic \
            protocol=templates seed=$((seed + 1)) output_root="$OUT/templates/$v-seed$((seed + 1))" \
            progress=false print_summary=false 2>/dev/null
        done ;;
      *) echo "make.sh: unknown part $part (clutter, ycbv, templates)" >&2; exit 2 ;;
    esac
  done
done
$PY experiments/robust_start/table.py "$OUT" results/robust_start/dev.md
seed_tables "$OUT" results/robust_start
