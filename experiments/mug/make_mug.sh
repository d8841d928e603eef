#!/usr/bin/env bash
# Issue 22, item 5: which change moved ours' mugs on the embedded set (protocol=templates, 3 category
# templates, seed 0) from 16.98 to 72.14 deg mean. Every solver x selection rule on the same inputs,
# then the shape generator before the CPU-independent geometry (revision 8236609) on the same code.
# Run from the repository root (bash experiments/mug/make_mug.sh); writes results/mug/table.md,
# table_oracle.md and old_shapes.txt.
set -euo pipefail
BENCH=${BENCH:-.venv/bin/bench}
PY=${PY:-.venv/bin/python}
OUT=outputs/mug
# choice=score: the study's rule (the protocol's default then; fused since)
$BENCH run -m method=ours dataset=synthetic protocol=templates choice=score 'dataset.categories=[mug]' \
  method.optimiser.solver=irls,adam method.selection.rule=visibility,chamfer,depth output_root=$OUT progress=false
$BENCH table --force $OUT/synthetic-templates --layout generic --format md --categories mug \
  --title "Embedded mugs, 3 category templates, seed 0: the estimate ours' own score chooses" --out results/mug/table.md
# the same runs scored by the best of the three templates' estimates (the oracle): what the choice costs
$BENCH table --force $OUT/synthetic-templates --layout generic --format md --categories mug --error oracle_err_deg \
  --title "Oracle: the best of the 3 category templates' estimates per view" --out results/mug/table_oracle.md
# the same runs with the mug meshes of the shape generator of revision 8236609 (git history), under the
# portable numeric profile: the old generator moves vertices by BLAS products, whose last bits depend on
# the kernel, so the "bit-identical" line would otherwise depend on the CPU
git show 8236609:datasets/shapes.py > $OUT/old_shapes.py
(eval "$($PY -m catpose.bench.run.environment portable)"
 $PY experiments/mug/old_shapes_check.py $OUT/old_shapes.py > results/mug/old_shapes.txt)
