#!/usr/bin/env bash
# The template choice on procedural chairs (issue 25; docs/category-level.md): 40 chairs drawn part
# by part (experiments/_lib/procedural.py and procedural_chairs.py, seed 0, root in $PROC_ROOT outside the repository), none of them
# a ModelNet40 shape, 6 views each.
#  1. Registered by ours and ICP to the paper table's K = 3 chair templates (chair_0391,
#     chair_0624, chair_0848, linked from the shared data): `experiments/_lib/category_table.py` writes chosen (every
#     rule) / oracle / random to chair_procedural_k3.{md,csv}, and top_weight_grid.py the
#     cross_top weight grid to chair_procedural_top_weight.md. cross_top's weight was chosen
#     before this set existed, on the real development chairs (make_chair_dev.sh).
#     The turn set of cross_top_turns (none, 90/270, 90/180/270) by the same grid, from a run of
#     ours that stores turns every 30 degrees: chair_procedural_turns.md; finer sets from the same
#     run: chair_procedural_turns_fine.md. The agreement angle of fused (fuse_grid.py):
#     chair_procedural_fuse.md; its own top-offset weight: chair_procedural_fuse_weight.md. The spread of the gap over 8-view draws (2 chairs x 4, as in the
#     paper table): chair_procedural_gap_spread.md.
#  2. K = 1, 3, 5 templates drawn from the procedural chairs themselves (make_any_root_ktemplates.sh
#     on a second root of the same 40 chairs without the shared ones): chair_procedural_any_root.{md,csv}.
# Usage (repository root): bash experiments/category_choice/make_chair_procedural.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PROC_ROOT=${PROC_ROOT:-$HOME/.cache/catpose/chair_procedural}
OUT=${OUT:-outputs/category_procedural}
DEV=results/category/dev
E=experiments/category_choice
FINE_TURNS="none;90,270;60,300;60,90,120,240,270,300;30,60,90,270,300,330;30,60,90,120,150,180,210,240,270,300,330"
.venv/bin/python experiments/_lib/procedural.py "$PROC_ROOT/with_templates" --category chair --count 40 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids chair_0391,chair_0624,chair_0848
"$B" run -m +experiment=mn40r_chair_ktemplates "+row=ours,icp" dataset.root="$PROC_ROOT/with_templates" \
  dataset.alignment_table="$PROC_ROOT/with_templates/alignment_chair.csv" dataset.views_per_instance=6 \
  output_root="$OUT" progress=false print_summary=false hydra.sweep.dir="$OUT/multirun/procedural_k3"
for fmt in md csv; do
  .venv/bin/python experiments/_lib/category_table.py --force "$OUT/multirun/procedural_k3" --category chair --choices cross,cross_top,cross_top_turns,fused,score,density,agreement \
    --format $fmt --out $DEV/chair_procedural_k3.$fmt \
    --title "Procedural chairs, K = 3 (40 chairs x 6 views; the paper table's templates)"
done
.venv/bin/python $E/top_weight_grid.py "$OUT/multirun/procedural_k3" --out $DEV/chair_procedural_top_weight.md \
  --title "Procedural chairs (40 x 6 views, K = 3, chosen nothing)"
# the fused rule's agreement angle (fuse_grid.py; the quarter turns read): chair_procedural_fuse.md
.venv/bin/python $E/fuse_grid.py "$OUT/multirun/procedural_k3" --out $DEV/chair_procedural_fuse.md \
  --title "Procedural chairs (40 x 6 views, K = 3), by agreement angle"
# and the fused rule's own top-offset weight at that angle (chair_procedural_fuse_weight.md; 0.075 kept,
# confirmed on the real development chairs: make_chair_dev.sh -> chair_dev_fuse_weight.md)
.venv/bin/python $E/fuse_grid.py "$OUT/multirun/procedural_k3" --angles 20 --weights 0.025,0.05,0.075,0.1,0.15,0.2 \
  --out $DEV/chair_procedural_fuse_weight.md --title "Procedural chairs (40 x 6 views, K = 3), by top-offset weight"
# the turn set of cross_top_turns: ours again with turns every 30 degrees stored, then the grid
# over no turns (cross_top), the quarter turns (the default) and with the half turn; then finer
# sets at the chosen weight (chair_procedural_turns_fine.md; none kept)
"$B" run -m +experiment=mn40r_chair_ktemplates "+row=ours" dataset.root="$PROC_ROOT/with_templates" \
  dataset.alignment_table="$PROC_ROOT/with_templates/alignment_chair.csv" dataset.views_per_instance=6 \
  "choice.turns_deg=[30,60,90,120,150,180,210,240,270,300,330]" output_root="$OUT" progress=false print_summary=false \
  hydra.sweep.dir="$OUT/multirun/procedural_k3_turns30"
.venv/bin/python $E/top_weight_grid.py "$OUT/multirun/procedural_k3_turns30" --turn-sets "none;90,270;90,180,270" \
  --out $DEV/chair_procedural_turns.md --title "Procedural chairs (40 x 6 views, K = 3), ours, by turn set"
.venv/bin/python $E/top_weight_grid.py "$OUT/multirun/procedural_k3_turns30" --turn-sets "$FINE_TURNS" --weights 0.05 \
  --out $DEV/chair_procedural_turns_fine.md --title "Procedural chairs (40 x 6 views, K = 3), ours, finer turn sets"
# how far 8 views (2 chairs x 4) can stand from the oracle by chance under the rule (gap_spread.py)
.venv/bin/python $E/gap_spread.py "$OUT/multirun/procedural_k3_turns30" --out $DEV/chair_procedural_gap_spread.md \
  --title "Procedural chairs (40 x 6 views, K = 3)"
.venv/bin/python experiments/_lib/procedural.py "$PROC_ROOT/alone" --category chair --count 40 --shape-seed 0
OUT="$OUT/any_root" ROWS="ours icp" TITLE="Procedural chairs, K templates drawn from them (40 chairs, 2 views of each non-template)" bash experiments/category_tables/make_any_root_ktemplates.sh "$PROC_ROOT/alone" \
  "$PROC_ROOT/alone/alignment_chair.csv" chair $DEV/chair_procedural_any_root.md
