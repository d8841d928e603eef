#!/usr/bin/env bash
# Ours' selection breadth on development shapes (issue 25; docs/category-level.md, "Why a view is
# wrong"): method.selection.top_k, how many of ours' candidates the point rule expands by their half
# turns and refines before it keeps the lowest score. Every run is ours on development shapes only,
# roots outside the repository:
#  1. the 80 procedural airplanes (experiments/_lib/procedural.py, seed 0) x 4 views, one template
#     (airplane_0536): top_k chosen on airplanes 8000-8039, confirmed on 8040-8079
#     (selection_airplane_procedural.md);
#  2. the 40 procedural chairs (experiments/_lib/procedural.py, seed 0) x 6 views, the paper table's K = 3
#     templates and its rule (fused) (selection_chair_procedural.md);
#  3. the 4 real development chairs (experiments/category_choice/chair_dev_root.py) x 12 views, the same templates and rule
#     (selection_chair_dev.md);
#  4. chairs with one template, under the chair K = 1 experiment's turn check: the 40 procedural chairs
#     x 6 views against chair_0624 (selection_chair_procedural_k1.md), and the 4 real development chairs
#     x 12 views against each of chair_0624, chair_0391 and chair_0848 (selection_chair_dev_k1.md);
#     settings 3 and 18 only.
# why_wrong then sorts the airplanes' wrong views at 3 and 18 (selection_airplane_procedural_why_{3,18}.md),
# and the K = 3 chairs' at 3, the default (chair_procedural_why.md, chair_dev_why.md).
# Usage (repository root): bash experiments/selection_breadth/make_selection_dev.sh (about 35 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
CACHE=${CACHE:-$HOME/.cache/catpose}
OUT=${OUT:-outputs/selection_dev}
DEV=results/category/dev
E=experiments/selection_breadth
AIR=$CACHE/airplane_procedural/n80
CHAIRS=$CACHE/chair_procedural/with_templates
CHAIRS_K1=$CACHE/chair_procedural/one_template
DEV_ROOT=$CACHE/chair_dev
TOP_K=${TOP_K:-3,6,9,12,18}
RUN=(output_root="$OUT" progress=false print_summary=false "+row=ours")
.venv/bin/python experiments/_lib/procedural.py "$AIR" --category airplane --count 80 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids airplane_0536 \
  --template-alignment results/alignment/modelnet40_resampled_airplane.csv
.venv/bin/python experiments/_lib/procedural.py "$CHAIRS" --category chair --count 40 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids chair_0391,chair_0624,chair_0848
.venv/bin/python experiments/_lib/procedural.py "$CHAIRS_K1" --category chair --count 40 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids chair_0624
.venv/bin/python experiments/category_choice/chair_dev_root.py "$SHARED" "$DEV_ROOT"
"$B" run -m +experiment=mn40r_airplane_1template "${RUN[@]}" dataset.root="$AIR" dataset.alignment_table="$AIR/alignment_airplane.csv" \
  dataset.views_per_instance=4 "method.selection.top_k=$TOP_K" hydra.sweep.dir="$OUT/multirun/airplanes"
.venv/bin/python $E/selection_grid.py "$OUT/multirun/airplanes" --key method.selection.top_k --split-at airplane_8040 \
  --out $DEV/selection_airplane_procedural.md --title "Procedural airplanes (80 x 4 views), one template (airplane_0536)"
"$B" run -m +experiment=mn40r_chair_ktemplates "${RUN[@]}" dataset.root="$CHAIRS" dataset.alignment_table="$CHAIRS/alignment_chair.csv" \
  dataset.views_per_instance=6 "method.selection.top_k=$TOP_K" hydra.sweep.dir="$OUT/multirun/chairs"
.venv/bin/python $E/selection_grid.py "$OUT/multirun/chairs" --key method.selection.top_k \
  --out $DEV/selection_chair_procedural.md --title "Procedural chairs (40 x 6 views), K = 3 (the paper table's templates, fused)"
"$B" run -m +experiment=mn40r_chair_ktemplates "${RUN[@]}" dataset.root="$DEV_ROOT" dataset.alignment_table="$DEV_ROOT/alignment_chair.csv" \
  dataset.views_per_instance=12 "method.selection.top_k=$TOP_K" hydra.sweep.dir="$OUT/multirun/chair_dev"
.venv/bin/python $E/selection_grid.py "$OUT/multirun/chair_dev" --key method.selection.top_k \
  --out $DEV/selection_chair_dev.md --title "Real development chairs (4 x 12 views), K = 3 (the paper table's templates, fused)"
"$B" run -m +experiment=mn40r_chair_1template "${RUN[@]}" dataset.root="$CHAIRS_K1" dataset.alignment_table="$CHAIRS_K1/alignment_chair.csv" \
  dataset.views_per_instance=6 "method.selection.top_k=3,18" hydra.sweep.dir="$OUT/multirun/chairs_k1"
.venv/bin/python $E/selection_grid.py "$OUT/multirun/chairs_k1" --key method.selection.top_k \
  --out $DEV/selection_chair_procedural_k1.md --title "Procedural chairs (40 x 6 views), one template (chair_0624, cross_top_turns)"
for t in chair_0624 chair_0391 chair_0848; do
  "$B" run -m +experiment=mn40r_chair_1template "${RUN[@]}" dataset.root="$DEV_ROOT" dataset.alignment_table="$DEV_ROOT/alignment_chair.csv" \
    dataset.views_per_instance=12 "dataset.templates.chair=[$t]" "method.selection.top_k=3,18" hydra.sweep.dir="$OUT/multirun/chair_dev_k1_$t"
done
.venv/bin/python $E/selection_grid.py "$OUT"/multirun/chair_dev_k1_chair_0{624,391,848} --key method.selection.top_k \
  --out $DEV/selection_chair_dev_k1.md \
  --title "Real development chairs (4 x 12 views), one template each (chair_0624, chair_0391, chair_0848 in turn; cross_top_turns)"
# the airplanes' wrong views sorted by why_wrong at the default and the widest setting
for k in 3 18; do
  .venv/bin/python experiments/_lib/why_wrong.py --force "$OUT/multirun/airplanes" --row ours --override method.selection.top_k=$k \
    --out $DEV/selection_airplane_procedural_why_$k.md --title "Procedural airplanes, one template (airplane_0536), ours, top_k $k"
done
# the K = 3 chairs' wrong views at the default (fused), sorted the same way: where the chair rule misses
# on development shapes (chair_procedural_why.md, chair_dev_why.md)
.venv/bin/python experiments/_lib/why_wrong.py --force "$OUT/multirun/chairs" --row ours --override method.selection.top_k=3 \
  --out $DEV/chair_procedural_why.md --title "Procedural chairs (40 x 6 views), K = 3 (fused), ours"
.venv/bin/python experiments/_lib/why_wrong.py --force "$OUT/multirun/chair_dev" --row ours --override method.selection.top_k=3 \
  --out $DEV/chair_dev_why.md --title "Real development chairs (4 x 12 views), K = 3 (fused), ours"
