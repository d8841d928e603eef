#!/usr/bin/env bash
# Ours under seeds 0-2 on both development sets: the shared YCB-V frames (bench suite real --sets ycbv: a
# column per scene, scene 1 the development part, and `agree`) and the clutter dev scenes 0-14 with
# segmenter-like masks (run_clutter.sh: @10 per seed and agree) -> results/check_separation/seeds_LABEL.md.
# Runs go to outputs/check_separation/LABEL (finished runs are kept: a rerun only tabulates).
# Usage (repository root): bash experiments/check_separation/make_seeds.sh LABEL [KEY=VALUE ...] (overrides of ours)
set -euo pipefail
LABEL=${1:?usage: make_seeds.sh LABEL [KEY=VALUE ...]}
shift
SUITE_O=()
for o in "$@"; do SUITE_O+=(-o "$o"); done
OUT=outputs/check_separation/$LABEL
T=results/check_separation/seeds_$LABEL.md
mkdir -p results/check_separation
clutter=$(OUT=$OUT/clutter bash experiments/check_separation/run_clutter.sh "$@" 2>/dev/null | sed 's#^.*/\(seed[0-9]\)-[^:]*:#\1:#')
nice .venv/bin/bench suite real --sets ycbv --methods ours --seeds 0,1,2 --output-root "$OUT/ycbv" ${SUITE_O[@]+"${SUITE_O[@]}"} --write "$T" --force >/dev/null
{ echo; echo "**Clutter dev scenes 0-14, segmenter-like masks (dataset.mask_noise=1): ours @10 per seed, and agree**"; echo
  echo '```'; echo "$clutter"; echo '```'; } >> "$T"
echo "$T"
