#!/usr/bin/env bash
# Ours with one key at a time set to its off or simplest value (run.py's VARIANTS) against ours' default,
# on the dev parts only: YCB-V scene 1 with segmenter-like masks (dataset.mask_noise=1), the clutter dev
# scenes 0-49 (dirty likewise), YCB-V scene 1 with its written masks; seeds 0-2; every variant of a batch
# on each problem back to back, into outputs/key_audit/<source>-seed<seed>/<variant>.jsonl (finished samples
# are kept), then the table results/key_audit/dev.md (table.py).
# Usage (repository root): bash experiments/key_audit/make.sh
#   BATCHES="A;B" runs those batches of variants in turn (each a comma list of run.py's names; default: the
#   study's order, README.md); PARTS="ycbv1dirty clutter0" runs only those sources (ycbv1dirty, clutter0-2,
#   ycbv1clean); NO_TABLE=1 skips the table; OUT and TABLE name the runs folder and the table.
# PARTS=templates: ours on the embedded set's development seeds 1-3 with category templates (protocol templates,
#   what the poor-fit fallback was for; not in the rule): the default, the drops but the fallback, the drops
#   together, into outputs/key_audit/templates/, then results/key_audit/templates.md. PARTS=ycbvtemplates: the
#   same three on YCB-V scene 1 with the category templates (the README's ycbv_templates set, its dev part),
#   seeds 0-2, into outputs/key_audit/ycbv_templates/, then results/key_audit/ycbv_templates.md.
set -euo pipefail
source experiments/_lib/seed_tables.sh
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PY=.venv/bin/python
OUT=${OUT:-outputs/key_audit}
DEFAULT_BATCHES="default,depth_min_inliers 0,depth_fit_erode_px 0,min_probability 0,grid_shift 0,grid_beam 0"
DEFAULT_BATCHES+=";grid_icp yaw,grid_icp full,depth_final_refine 1,depth_top_k 1,depth_final_pixels 1200"
DEFAULT_BATCHES+=";depth_free_weight 0,depth_free_weight 1,gravity_max_deg null,refine false"
DEFAULT_BATCHES+=";max_poses 0,grid_yaws 0"
CLUTTER=(dataset=clutter "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[$(seq -s, 0 49)]" dataset.mask_noise=1.0)
YCBV=(dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]")
IFS=';' read -ra batches <<< "${BATCHES:-$DEFAULT_BATCHES}"
for variants in "${batches[@]}"; do
  for part in ${PARTS:-ycbv1dirty clutter0 clutter1 clutter2 ycbv1clean}; do
    case $part in
      clutter[0-2]) nice -n 5 $PY experiments/key_audit/run.py "$OUT/clutter-seed${part#clutter}" "${part#clutter}" \
        "$variants" "${CLUTTER[@]}" 2>/dev/null ;;
      ycbv1dirty|ycbv1clean)
        noise=1.0; [ $part = ycbv1clean ] && noise=0.0
        for seed in 0 1 2; do
          nice -n 5 $PY experiments/key_audit/run.py "$OUT/$part-seed$seed" "$seed" "$variants" "${YCBV[@]}" \
            "dataset.mask_noise=$noise" 2>/dev/null
        done ;;
      templates)
        S=method.selection. R=method.resting.
        DROPS="${R}grid_icp=full ${S}depth_final_refine=1 ${S}depth_top_k=1"
        for row in "default:" "the-drops-but-the-fallback:$DROPS" \
          "the-drops-together:$DROPS ${S}depth_min_inliers=0 ${S}gravity_max_deg=null"; do
          for seed in 1 2 3; do
            # shellcheck disable=SC2086  # the overrides are words
            nice -n 5 .venv/bin/bench run method=ours dataset=synthetic protocol=templates seed=$seed \
              output_root="$OUT/templates/${row%%:*}-seed$seed" progress=false print_summary=false ${row#*:}
          done
        done ;;
      ycbvtemplates)
        S=method.selection. R=method.resting.
        DROPS="${R}grid_icp=full ${S}depth_final_refine=1 ${S}depth_top_k=1"
        AXES=$(for c in can bottle bowl mug; do printf '+dataset.symmetric.%s=[0,0,1] ' $c; done)
        for row in "default:" "the-drops-but-the-fallback:$DROPS" \
          "the-drops-together:$DROPS ${S}depth_min_inliers=0 ${S}gravity_max_deg=null"; do
          for seed in 0 1 2; do
            # shellcheck disable=SC2086  # the overrides are words
            nice -n 5 .venv/bin/bench run method=ours dataset=ycbv "dataset.root=$SHARED/bop/ycbv" "dataset.scenes=[1]" \
              protocol=templates $AXES seed=$seed output_root="$OUT/ycbv_templates/${row%%:*}-seed$seed" \
              progress=false print_summary=false ${row#*:}
          done
        done ;;
      *) echo "make.sh: unknown part $part (ycbv1dirty, clutter0-2, ycbv1clean, templates, ycbvtemplates)" >&2; exit 2 ;;
    esac
  done
done
if [ -z "${NO_TABLE:-}" ]; then
  $PY experiments/key_audit/table.py "$OUT" "${TABLE:-results/key_audit/dev.md}"
  seed_tables "$OUT" results/key_audit
fi
