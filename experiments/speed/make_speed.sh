#!/usr/bin/env bash
# Seconds per registration (bench perf) on synthetic, YCB-V and ModelNet40 problems, the first
# sample of a template in a new process (first_sample.py), and the speed tables made from those
# CSVs and the GPU check's (summary.py): results/perf/ (README.md). Run it on an otherwise idle
# machine: it measures wall time. The GPU check's gpu_solver_<device>.csv come from
# `python3 experiments/speed/gpu.py --out results/perf/gpu_solver_<device>.csv` on a GPU machine.
# Run from the repository root (results/make_results.sh, section perf). Environment: RESULTS
# (default results), PY, BENCH.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
P=${RESULTS:-results}/perf
SHARED=$("$PY" -c 'from catpose.bench.run.config import shared_data_dir; print(shared_data_dir())')
mkdir -p "$P"
M=ours,adam=ours,icp,fgr,teaser,ransac,ppf
# one thread: every method as it runs on one core
"$BENCH" perf --n 12 --repeat 3 --threads 1 --methods $M --set adam:optimiser.solver=adam --out "$P/perf_synthetic.csv"
if [ -d "$SHARED/bop/ycbv" ]; then
  "$BENCH" perf --n 12 --repeat 3 --threads 1 --methods $M --set adam:optimiser.solver=adam --dataset ycbv \
    --root "$SHARED/bop/ycbv" --out "$P/perf_ycbv.csv"
fi
# ours with its compiled search split over both CPUs (threads=2, what the default threads=auto
# takes on a 2-CPU machine; the same results as threads=1)
"$BENCH" perf --n 12 --repeat 3 --methods ours,fgr --threads 2 --out "$P/perf_synthetic_threads2.csv"
if [ -d "$SHARED/bop/ycbv" ]; then
  "$BENCH" perf --n 12 --repeat 3 --methods ours,fgr --threads 2 --dataset ycbv --root "$SHARED/bop/ycbv" \
    --out "$P/perf_ycbv_threads2.csv"
  # the first registration of a template in a new process, cache cold and warm
  "$PY" experiments/speed/first_sample.py --dataset ycbv --root "$SHARED/bop/ycbv" --templates 3 --repeat 3 \
    --out "$P/first_sample_ycbv.csv"
fi
if [ -d "$SHARED/ModelNet40" ]; then
  "$BENCH" perf --n 12 --repeat 3 --threads 1 --methods ours,fgr --dataset modelnet40 --root "$SHARED/ModelNet40" \
    --out "$P/perf_modelnet40.csv"
fi
"$PY" experiments/speed/summary.py --dir "$P"
