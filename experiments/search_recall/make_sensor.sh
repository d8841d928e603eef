#!/usr/bin/env bash
# The clutter set's frames beside the 19 real YCB-V frames (README.md): missing depth, segmentation
# against depth, residuals to the model at the written truth, camera distance and elevation ->
# results/search_recall/sensor_vs_real.md. Generates the first 40 clutter scenes if missing.
set -euo pipefail
PY=${PY:-.venv/bin/python}
$PY experiments/_lib/sensor_stats.py --clutter --scenes 40 --out results/search_recall/sensor_vs_real.md
