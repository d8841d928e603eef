#!/usr/bin/env bash
# Seconds per registration (bench perf, warm caches, interleaved rounds) of ours at its defaults beside
# its coarse search with the ground-normal ICP alone (yaw), issue 44's first coarse search (free ICP,
# beam 16) and FGR, on the shared YCB-V frames and the embedded set -> results/search_recall/perf_*.csv
# (README.md). One thread each. The median / FGR's column compares machines; the absolute seconds are this machine's.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
eval "$($PY -m catpose.bench.run.environment portable)"
# issue 22's search set options that issue 58 removed; its row ran at commit 9c64f33 (git checkout 9c64f33)
OLD=(--set issue44:resting.grid_icp=full --set issue44:resting.grid_beam=16
  --set issue44:selection.depth_tau=0.1 --set issue44:selection.depth_free_weight=1.0 --set yaw:resting.grid_icp=yaw
  --set issue44:resting.grid_shift=0.0 --set yaw:resting.grid_shift=0.0)
$BENCH perf --n 12 --repeat 3 --threads 1 --methods ours,yaw=ours,issue44=ours,fgr "${OLD[@]}" --out results/search_recall/perf_synthetic.csv
$BENCH perf --n 12 --repeat 3 --threads 1 --methods ours,yaw=ours,issue44=ours,fgr "${OLD[@]}" --dataset ycbv --root "$SHARED/bop/ycbv" \
  --out results/search_recall/perf_ycbv.csv
