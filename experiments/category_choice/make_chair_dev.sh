#!/usr/bin/env bash
# The development table of the template choice (issue 25; docs/category-level.md): 4 chairs that
# are not among the shared resampled ones (chair_dev_root.py builds their root in $DEV_ROOT,
# outside the repository, from the shared data), 12 views each, registered by ours and ICP to the
# K = 3 chair templates of the paper table (chair_0391, chair_0624, chair_0848); `experiments/_lib/category_table.py`
# writes chosen (rules cross, cross_top, score, density, agreement) / oracle / random side by side to
# results/category/dev/chair_dev_k3.{md,csv}. The cross rule's weight was chosen on these runs
# (and on development airplanes that cannot be shared), cross_top's top-offset weight on these runs
# alone (top_weight_grid.py -> chair_dev_top_weight.md); the paper table's chairs only report them.
# The agreement angle of fused (fuse_grid.py): chair_dev_fuse.md; its top-offset weight: chair_dev_fuse_weight.md.
# Finer turn sets of cross_top_turns (ours, turns every 30 degrees stored): chair_dev_turns_fine.md;
# the spread of the gap to the oracle over 8-view draws: chair_dev_gap_spread.md (gap_spread.py).
# Usage (repository root): bash experiments/category_choice/make_chair_dev.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
DEV_ROOT=${DEV_ROOT:-$HOME/.cache/catpose/chair_dev}
OUT=${OUT:-outputs/category_dev}
# dev_run ROWS SWEEP [OVERRIDE ...]: the chair experiment on the development root, 12 views per chair
dev_run() {
  "$B" run -m +experiment=mn40r_chair_ktemplates "+row=$1" dataset.root="$DEV_ROOT" \
    dataset.alignment_table="$DEV_ROOT/alignment_chair.csv" dataset.views_per_instance=12 output_root="$OUT" \
    progress=false print_summary=false hydra.sweep.dir="$OUT/multirun/$2" "${@:3}"
}
.venv/bin/python experiments/category_choice/chair_dev_root.py "$SHARED" "$DEV_ROOT"
dev_run ours,icp chair_dev_k3
for fmt in md csv; do
  .venv/bin/python experiments/_lib/category_table.py --force "$OUT/multirun/chair_dev_k3" --category chair --choices cross,cross_top,cross_top_turns,fused,score,density,agreement --format $fmt \
    --out results/category/dev/chair_dev_k3.$fmt \
    --title "Chair development set, K = 3 (chair_0001, chair_0002, chair_0059, ShapeNet chair x 12 views)"
done
SWAPS=(chair_0001,chair_0059,chair_9001 chair_0002,chair_0391,chair_0848 chair_0059,chair_0624,chair_9001
       chair_0001,chair_0002,chair_0624)
for i in "${!SWAPS[@]}"; do
  dev_run ours,icp chair_dev_swap$i "dataset.templates.chair=[${SWAPS[$i]}]" "protocol.exclude_instances=[]"
done
for fmt in md csv; do
  .venv/bin/python experiments/_lib/category_table.py --force "$OUT"/multirun/chair_dev_swap{0,1,2,3} --category chair --choices cross,cross_top,cross_top_turns,fused,score,density,agreement \
    --format $fmt --out results/category/dev/chair_dev_swaps.$fmt \
    --title "Chair development set, roles swapped: 4 template sets of K = 3 from the 7 non-report chairs, the other 4 chairs x 12 views"
done
# the cross_top rule's top-offset weight on the same runs (reads their stored costs)
.venv/bin/python experiments/category_choice/top_weight_grid.py "$OUT"/multirun/chair_dev_k3 "$OUT"/multirun/chair_dev_swap{0,1,2,3} \
  --out results/category/dev/chair_dev_top_weight.md
# and with the quarter turns (cross_top_turns, chosen on the procedural chairs: make_chair_procedural.sh)
.venv/bin/python experiments/category_choice/top_weight_grid.py "$OUT"/multirun/chair_dev_k3 "$OUT"/multirun/chair_dev_swap{0,1,2,3} \
  --turn-sets "none;90,270" --out results/category/dev/chair_dev_turns.md --title "Chair development runs, by turn set"
# the fused rule's agreement angle (chosen on the procedural chairs: make_chair_procedural.sh)
.venv/bin/python experiments/category_choice/fuse_grid.py "$OUT"/multirun/chair_dev_k3 "$OUT"/multirun/chair_dev_swap{0,1,2,3} \
  --out results/category/dev/chair_dev_fuse.md --title "Chair development runs, by agreement angle"
# and its top-offset weight at that angle (chosen on the procedural chairs: make_chair_procedural.sh)
.venv/bin/python experiments/category_choice/fuse_grid.py "$OUT"/multirun/chair_dev_k3 "$OUT"/multirun/chair_dev_swap{0,1,2,3} \
  --angles 20 --weights 0.025,0.05,0.075,0.1,0.15,0.2 --out results/category/dev/chair_dev_fuse_weight.md \
  --title "Chair development runs, by top-offset weight"
# finer turn sets (none kept): ours again on the same 5 template sets with turns every 30 degrees
T30="[30,60,90,120,150,180,210,240,270,300,330]"
dev_run ours chair_dev_k3_turns30 "choice.turns_deg=$T30"
for i in "${!SWAPS[@]}"; do
  dev_run ours chair_dev_swap${i}_turns30 "dataset.templates.chair=[${SWAPS[$i]}]" "protocol.exclude_instances=[]" "choice.turns_deg=$T30"
done
.venv/bin/python experiments/category_choice/top_weight_grid.py "$OUT"/multirun/chair_dev_k3_turns30 "$OUT"/multirun/chair_dev_swap{0,1,2,3}_turns30 \
  --turn-sets "none;90,270;60,300;60,90,120,240,270,300;30,60,90,270,300,330;30,60,90,120,150,180,210,240,270,300,330" \
  --weights 0.05 --out results/category/dev/chair_dev_turns_fine.md --title "Chair development runs, ours, finer turn sets"
# how far 8 views (2 chairs x 4, as in the paper table) can stand from the oracle by chance
.venv/bin/python experiments/category_choice/gap_spread.py "$OUT"/multirun/chair_dev_k3 "$OUT"/multirun/chair_dev_swap{0,1,2,3} \
  --out results/category/dev/chair_dev_gap_spread.md --title "Chair development runs (5 template sets)"
