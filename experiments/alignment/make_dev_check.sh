#!/usr/bin/env bash
# The development measurement of align.py (what its cues and weights were chosen on): 161
# ModelNet40 TRAIN-split airplanes that are not among the 18 shared ones (results/alignment/dev/ids.txt:
# 116 drawn at random, 45 among the least typical shapes), each checked by eye on contact sheets
# (results/alignment/dev/modelnet40_resampled_airplane.csv: nose at +x, z up; 19 drawn airplanes whose
# fuselage is not on a 90-degree yaw, or that are rolled, were left out). Their files are not in this
# repository: give the folder of a modelnet40_normal_resampled copy that holds them.
# Settings as in development: 512 points, no ICP refinement (--no-refine), 4 and 8 hypotheses.
# Output: results/alignment/dev/summary.md (agreement and confidence ROC per set). The per-shape rows
# (estimated*.csv, _vs_verified.csv) describe shapes that are not in this repository and stay out of
# it: they go to $OUT (default outputs/alignment/dev, ignored by git); contact sheets are not kept.
# Usage (repository root): bash experiments/alignment/make_dev_check.sh /path/to/modelnet40_normal_resampled
set -euo pipefail
cd "$(dirname "$0")/../.."
SRC=${1:?give the modelnet40_normal_resampled folder that holds the ids of results/alignment/dev/ids.txt}
D=results/alignment/dev
O=${OUT:-outputs/alignment/dev}
mkdir -p "$O"
ROOT=$(mktemp -d)
trap 'rm -rf "$ROOT"' EXIT
mkdir -p "$ROOT/airplane"
while read -r id; do
  [ -f "$SRC/airplane/$id.txt" ] || { echo "error: $SRC/airplane/$id.txt is missing" >&2; exit 2; }
  ln -s "$(cd "$SRC/airplane" && pwd)/$id.txt" "$ROOT/airplane/$id.txt"
done < "$D/ids.txt"
cp "$D/ids.txt" "$ROOT/modelnet40_train.txt"
: > "$ROOT/modelnet40_test.txt"
items=()
for flip in "" --flip; do
  sfx=${flip:+_flip}
  .venv/bin/python experiments/alignment/align.py dataset=modelnet40_resampled dataset.root="$ROOT" "dataset.categories=[airplane]" --category airplane \
    --points 512 --no-refine $flip --force --out "$O/estimated$sfx.csv" --sheet "$ROOT/sheet$sfx.png" \
    --compare "$D/modelnet40_resampled_airplane.csv"
  items+=("development airplanes${flip:+ (8 hypotheses)}=$O/estimated${sfx}_vs_verified.csv")
done
.venv/bin/python experiments/alignment/align_summary.py "${items[@]}" --out "$D/summary.md"
