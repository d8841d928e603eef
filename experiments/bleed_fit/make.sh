#!/usr/bin/env bash
# experiments/bleed_fit (README.md): ours' poor-fit test as it is (default) and bleed-aware, on the dev parts
# (clutter dev 0-49 and YCB-V scene 1, dirty and written masks; seeds 0-2) into
# outputs/bleed_fit/<source>-seed<seed>/<variant>.jsonl, and with the category templates (the embedded set,
# seeds 1-3; YCB-V scene 1, seeds 0-2) into outputs/bleed_fit/{templates,ycbv_templates}/; then
# results/bleed_fit/dev.md (experiments/robust_start/table.py's layout), templates.md and ycbv_templates.md.
# Usage (repository root): bash experiments/bleed_fit/make.sh   (PARTS="clutter ycbv templates" by default)
set -euo pipefail
source experiments/_lib/seed_tables.sh
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
OUT=${OUT:-outputs/bleed_fit}
RUN=experiments/bleed_fit/run.py
V="default,bleed-aware"
CLUTTER=(dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]")
YCBV=(dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]")
AXES=$(for c in can bottle bowl mug; do printf '+dataset.symmetric.%s=[0,0,1] ' $c; done)
for part in ${PARTS:-clutter ycbv templates}; do
  for seed in 0 1 2; do
    case $part in
      clutter)
        nice -n 5 $PY $RUN "$OUT/clutter-seed$seed" $seed "$V" "${CLUTTER[@]}" dataset.mask_noise=1.0 2>/dev/null
        nice -n 5 $PY $RUN "$OUT/clutterclean-seed$seed" $seed "$V" "${CLUTTER[@]}" 2>/dev/null ;;
      ycbv)
        nice -n 5 $PY $RUN "$OUT/ycbv1dirty-seed$seed" $seed "$V" "${YCBV[@]}" dataset.mask_noise=1.0 2>/dev/null
        nice -n 5 $PY $RUN "$OUT/ycbv1clean-seed$seed" $seed "$V" "${YCBV[@]}" 2>/dev/null ;;
      templates)
        for v in default bleed-aware; do
          nice -n 5 $PY $RUN --bench $v run method=ours dataset=synthetic protocol=templates seed=$((seed + 1)) \
            output_root="$OUT/templates/$v-seed$((seed + 1))" progress=false print_summary=false 2>/dev/null
          # shellcheck disable=SC2086  # the overrides are words
          nice -n 5 $PY $RUN --bench $v run method=ours dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]" \
            protocol=templates $AXES seed=$seed output_root="$OUT/ycbv_templates/$v-seed$seed" \
            progress=false print_summary=false 2>/dev/null
        done ;;
      *) echo "make.sh: unknown part $part (clutter, ycbv, templates)" >&2; exit 2 ;;
    esac
  done
done
mkdir -p results/bleed_fit
$PY experiments/robust_start/table.py "$OUT" results/bleed_fit/dev.md bleed-aware experiments/bleed_fit/README.md
seed_tables "$OUT" results/bleed_fit
