#!/usr/bin/env bash
# The one-template turn check (cross_top_turns with choice.one_template_turns=true; chosen for
# airplanes on procedural airplanes, make_airplane_procedural.sh) tried on another category, chairs
# (docs/category-level.md): ours and ICP at K = 1, each estimate's turns about up by 90, 180 and 270
# degrees stored, then top_weight_grid.py over turn sets at weights 0 and 0.05 (with one template
# the oracle is the registration's own estimate, so a gap below 0 is what the check gains):
#  1. the 40 procedural chairs (experiments/_lib/procedural.py, seed 0) x 6 views against the chair
#     experiment's K = 1 template chair_0624: chair_procedural_one_template.md;
#  2. the 4 real development chairs (chair_dev_root.py) x 12 views against each of the three paper
#     templates alone (chair_0624, chair_0391, chair_0848): chair_dev_one_template.md.
# Roots in $PROC_ROOT and $DEV_ROOT, outside the repository. Usage (repository root):
#   bash experiments/category_choice/make_chair_one_template.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PROC_ROOT=${PROC_ROOT:-$HOME/.cache/catpose/chair_procedural/one_template}
DEV_ROOT=${DEV_ROOT:-$HOME/.cache/catpose/chair_dev}
OUT=${OUT:-outputs/category_chair_one_template}
DEV=results/category/dev
E=experiments/category_choice
CHECK=(choice=cross_top_turns "choice.turns_deg=[90,180,270]" choice.one_template_turns=true
       "+row=ours,icp" output_root="$OUT" progress=false print_summary=false)
SETS="none;90,270;180;90,180,270"
.venv/bin/python experiments/_lib/procedural.py "$PROC_ROOT" --category chair --count 40 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids chair_0624
"$B" run -m +experiment=mn40r_chair_1template "${CHECK[@]}" dataset.root="$PROC_ROOT" \
  dataset.alignment_table="$PROC_ROOT/alignment_chair.csv" dataset.views_per_instance=6 hydra.sweep.dir="$OUT/multirun/procedural"
.venv/bin/python $E/top_weight_grid.py "$OUT/multirun/procedural" --turn-sets "$SETS" --weights 0,0.05 \
  --out $DEV/chair_procedural_one_template.md \
  --title "Procedural chairs (40 x 6 views), one template (chair_0624), by turn set; the oracle is the own estimate"
.venv/bin/python $E/chair_dev_root.py "$SHARED" "$DEV_ROOT"
for t in chair_0624 chair_0391 chair_0848; do
  "$B" run -m +experiment=mn40r_chair_1template "${CHECK[@]}" dataset.root="$DEV_ROOT" "dataset.templates.chair=[$t]" \
    dataset.alignment_table="$DEV_ROOT/alignment_chair.csv" dataset.views_per_instance=12 hydra.sweep.dir="$OUT/multirun/dev_$t"
done
.venv/bin/python $E/top_weight_grid.py "$OUT"/multirun/dev_chair_{0624,0391,0848} --turn-sets "$SETS" --weights 0,0.05 \
  --out $DEV/chair_dev_one_template.md \
  --title "Chair development set (4 chairs x 12 views), one template (sets: chair_0624, chair_0391, chair_0848), by turn set; the oracle is the own estimate"
