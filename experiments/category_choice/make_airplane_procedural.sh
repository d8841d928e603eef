#!/usr/bin/env bash
# The one-template airplane choice on procedural airplanes (issue 25; docs/category-level.md): 80
# airplanes drawn part by part (experiments/_lib/procedural.py and procedural_airplanes.py, seed 0, root in $PROC_ROOT outside the
# repository: airliners, propeller planes, fighters, biplanes, gliders), none of them a ModelNet40
# shape, 4 views each, registered by ours and ICP to the one-template experiment's template
# (airplane_0536, linked from the shared data with its verified alignment row). The run stores each
# estimate's turns about up by 90, 180 and 270 degrees (choice.turns_deg), so one_template_turns.py
# reads cross_top_turns over every subset and top-offset weight without registering again. The
# setting was chosen on airplanes 8000-8039 and confirmed on 8040-8079:
# airplane_procedural_one_template.md.
# Usage (repository root): bash experiments/category_choice/make_airplane_procedural.sh (about 10 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/../.."
# the portable numeric profile, as results/make_results.sh sets it: the same bits on any AVX2 or AVX-512 CPU
eval "$(.venv/bin/python -m catpose.bench.run.environment portable)"
B=.venv/bin/bench
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
PROC_ROOT=${PROC_ROOT:-$HOME/.cache/catpose/airplane_procedural/n80}
OUT=${OUT:-outputs/airplane_procedural}
DEV=results/category/dev
E=experiments/category_choice
.venv/bin/python experiments/_lib/procedural.py "$PROC_ROOT" --category airplane --count 80 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids airplane_0536 \
  --template-alignment results/alignment/modelnet40_resampled_airplane.csv
"$B" run -m +experiment=mn40r_airplane_1template "+row=ours,icp" dataset.root="$PROC_ROOT" \
  dataset.alignment_table="$PROC_ROOT/alignment_airplane.csv" dataset.views_per_instance=4 \
  choice=cross_top_turns "choice.turns_deg=[90,180,270]" choice.one_template_turns=true output_root="$OUT" progress=false print_summary=false \
  hydra.sweep.dir="$OUT/multirun/k1_turns_n80"
.venv/bin/python $E/one_template_turns.py "$OUT/multirun/k1_turns_n80" --alignment "$PROC_ROOT/alignment_airplane.csv" \
  --split-at airplane_8040 --keep "180@0.05" --out $DEV/airplane_procedural_one_template.md \
  --title "Procedural airplanes (80 x 4 views), one template (airplane_0536)"
# The same 80 airplanes against the shared K = 3 airplane templates (configs/category_templates/
# mn40r_airplane_k3.yaml), 2 views each, ours, turns stored: every rule of `experiments/_lib/category_table.py` and the
# top-offset / turn-set grid (airplane_procedural_k3.md, airplane_procedural_k3_grid.md). Not used to
# change the airplane experiments' rule (docs/category-level.md).
K3_ROOT=${K3_ROOT:-$PROC_ROOT-k3}
.venv/bin/python experiments/_lib/procedural.py "$K3_ROOT" --category airplane --count 80 --shape-seed 0 \
  --template-root "$SHARED/modelnet40_normal_resampled" --template-ids airplane_0002,airplane_0256,airplane_0432 \
  --template-alignment results/alignment/modelnet40_resampled_airplane.csv
"$B" run -m +experiment=mn40r_airplane_ktemplates "+row=ours" +category_templates=mn40r_airplane_k3 \
  "protocol.exclude_instances=[airplane_0002,airplane_0256,airplane_0432]" dataset.root="$K3_ROOT" \
  dataset.alignment_table="$K3_ROOT/alignment_airplane.csv" dataset.views_per_instance=2 "choice.turns_deg=[90,180,270]" \
  output_root="$OUT/k3" progress=false print_summary=false hydra.sweep.dir="$OUT/k3/multirun/k3"
.venv/bin/python experiments/_lib/category_table.py --force "$OUT/k3/multirun/k3" --category airplane --choices cross,cross_top,cross_top_turns,score,density,agreement \
  --format md --out $DEV/airplane_procedural_k3.md \
  --title "Procedural airplanes, K = 3 (80 airplanes x 2 views; the shared airplane K = 3 templates)"
.venv/bin/python $E/top_weight_grid.py "$OUT/k3/multirun/k3" --turn-sets "none;180;90,270;90,180,270" --weights 0,0.05 \
  --out $DEV/airplane_procedural_k3_grid.md --title "Procedural airplanes (80 x 2 views, K = 3), ours, by turn set"
