#!/usr/bin/env bash
# align.py with no table and no person on the four shared sets (OFF and resampled; airplane and
# chair), 4 yaw hypotheses (the default) and 8 (--flip: the up axis may be turned over too); each
# estimate is then compared with the verified table (agreement up to one common rotation, and the ROC
# of the confidence as a detector of right rows). The verified tables are read only by --compare,
# after the estimate is written. Output: results/alignment/estimated/ (<set>[_flip].csv, .png,
# _vs_verified.csv) and summary.md.
# Usage (repository root, after `make setup`): bash experiments/alignment/make_estimates.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${CATPOSE_SHARED_DATA:-../shared/data}
E=results/alignment/estimated
mkdir -p "$E"
items=()
for flip in "" --flip; do
  sfx=${flip:+_flip}
  for cat in airplane chair; do
    .venv/bin/python experiments/alignment/align.py dataset=modelnet40 dataset.root="$D/ModelNet40" "dataset.categories=[$cat]" --category $cat \
      --reference ${cat}_0001 $flip --force --out "$E/modelnet40_$cat$sfx.csv" --compare results/alignment/modelnet40_$cat.csv
    ref=$([ $cat = airplane ] && echo airplane_0001 || echo chair_0391)
    .venv/bin/python experiments/alignment/align.py dataset=modelnet40_resampled dataset.root="$D/modelnet40_normal_resampled" "dataset.categories=[$cat]" \
      --category $cat --reference $ref $flip --force --out "$E/modelnet40_resampled_$cat$sfx.csv" \
      --compare results/alignment/modelnet40_resampled_$cat.csv
    items+=("OFF $cat${flip:+ (8 hypotheses)}=$E/modelnet40_${cat}${sfx}_vs_verified.csv"
            "resampled $cat${flip:+ (8 hypotheses)}=$E/modelnet40_resampled_${cat}${sfx}_vs_verified.csv")
  done
done
.venv/bin/python experiments/alignment/align_summary.py "${items[@]}" --out "$E/summary.md"
