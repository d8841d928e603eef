#!/usr/bin/env bash
# Seconds per registration (bench perf, warm caches, interleaved rounds) of ours at its defaults beside
# its coarse search with the ground-normal ICP alone (yaw), issue 44's first coarse search (free ICP,
# beam 16), issue 22's search (no coarse search, the dictionary on other resting poses below 0.95 inliers, the
# upright prior) and FGR, on the shared YCB-V frames and the embedded set -> results/search_recall/perf_*.csv
# (README.md). One thread each. The median / FGR's column compares machines; the absolute seconds are this machine's.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
eval "$($PY -m catpose.bench.run.environment portable)"
OLD=(--set issue22:resting.grid_yaws=0 --set issue22:resting.max_poses=5 --set issue22:resting.min_probability=0.05
  --set issue22:resting.escalate_below=0.95 --set issue22:selection.depth_rest_prior=0.03
  --set issue22:selection.depth_half_turns=true --set issue22:selection.depth_final_refine=1
  --set issue22:selection.depth_tau=0.1 --set issue22:selection.depth_free_weight=1.0
  --set issue44:resting.grid_icp=full --set issue44:resting.grid_beam=16
  --set issue22:selection.depth_final_distinct_deg=0
  --set issue44:selection.depth_tau=0.1 --set issue44:selection.depth_free_weight=1.0
  --set issue44:selection.depth_final_distinct_deg=0 --set yaw:resting.grid_icp=yaw
  --set issue44:resting.grid_shift=0.0 --set yaw:resting.grid_shift=0.0)
$BENCH perf --n 12 --repeat 3 --threads 1 --methods ours,yaw=ours,issue44=ours,issue22=ours,fgr "${OLD[@]}" --out results/search_recall/perf_synthetic.csv
$BENCH perf --n 12 --repeat 3 --threads 1 --methods ours,yaw=ours,issue44=ours,issue22=ours,fgr "${OLD[@]}" --dataset ycbv --root "$SHARED/bop/ycbv" \
  --out results/search_recall/perf_ycbv.csv
