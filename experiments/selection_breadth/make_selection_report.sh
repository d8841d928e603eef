#!/usr/bin/env bash
# Ours' selection breadth (method.selection.top_k: 3, the default, and 18, every candidate) reported on
# the shared shapes of the paper's category tables: one template airplane, chairs K = 1 and K = 3,
# ours only (results/category/paper/selection_top_k_{airplane,chair_k3,chair_k1}.md; why_wrong on the airplanes
# at 18: selection_top_k_airplane_why.md). The setting was
# studied on development shapes only (experiments/selection_breadth/make_selection_dev.sh) and is not a default:
# these runs report it, they chose nothing (docs/category-level.md, "Why a view is wrong").
# Usage (repository root, after `make setup`): bash experiments/selection_breadth/make_selection_report.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
OUT=${OUT:-outputs/category_selection}
T=results/category/paper
for e in mn40r_airplane_1template mn40r_chair_ktemplates mn40r_chair_1template; do
  "$B" run -m +experiment=$e "+row=ours" "method.selection.top_k=3,18" output_root="$OUT" progress=false \
    print_summary=false hydra.sweep.dir="$OUT/multirun/selection_$e"
done
G=experiments/selection_breadth/selection_grid.py
.venv/bin/python $G "$OUT/multirun/selection_mn40r_airplane_1template" --key method.selection.top_k --out $T/selection_top_k_airplane.md \
  --title "One template (airplane_0536), shared resampled airplanes (17 x 2 views), ours"
.venv/bin/python $G "$OUT/multirun/selection_mn40r_chair_ktemplates" --key method.selection.top_k --out $T/selection_top_k_chair_k3.md \
  --title "Chair, K = 3 (fused), shared resampled chairs (2 x 4 views), ours"
.venv/bin/python $G "$OUT/multirun/selection_mn40r_chair_1template" --key method.selection.top_k --out $T/selection_top_k_chair_k1.md \
  --title "Chair, one template (chair_0624, cross_top_turns), shared resampled chairs (2 x 4 views), ours"
# the airplanes' wrong views at 18, sorted as at the default (one_template_airplane_why.md)
.venv/bin/python experiments/_lib/why_wrong.py --force "$OUT/multirun/selection_mn40r_airplane_1template" --row ours \
  --override method.selection.top_k=18 --out $T/selection_top_k_airplane_why.md \
  --title "Why ours' wrong views are wrong with method.selection.top_k=18: one template (airplane_0536), shared resampled airplanes"
