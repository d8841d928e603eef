#!/usr/bin/env bash
# Why ours' wrong estimates won (python experiments/_lib/ambiguity.py): for every wrong estimate of
# ours' default, the template rendered at the estimate and at the ground truth, scored by ours'
# depth check. "search miss": the truth explains the image better, ours did not find it;
# "ambiguous": the estimate explains it at least as well. Reads the run directories that
# results/make_results.sh wrote (sections synthetic, clutter, real; nothing is run here):
#   ambiguity/clutter.md   the cluttered synthetic set, dev and report scenes (configs/split/clutter.yaml)
#   ambiguity/ycbv.md      the shared real YCB-V frames, per scene (configs/split/ycbv.yaml)
#   ambiguity/embedded_own.md, embedded_templates.md  the embedded set: own model; the 3 category
#                          templates (every registration of every view)
# Usage (repository root): bash experiments/ambiguity/make_ambiguity.sh
#   OUT: make_results' run folder (default outputs/results); CLUTTER_RUNS: the clutter runs
#   (default $OUT/clutter); RESULTS: where the tables go (default results).
set -euo pipefail
cd "$(dirname "$0")/../.."
PY=.venv/bin/python
OUT=${OUT:-outputs/results}
CLUTTER_RUNS=${CLUTTER_RUNS:-$OUT/clutter}
T=${RESULTS:-results}/ambiguity
source experiments/default_runs.sh
need() { [ -n "$2" ] || { echo "make_ambiguity: no runs of ours' default in $1; run results/make_results.sh first" >&2; exit 2; }; }
mapfile -t clutter < <(default_runs "$CLUTTER_RUNS/clutter-gt_model/ours"); need "$CLUTTER_RUNS" "${clutter[*]:-}"
"$PY" experiments/_lib/ambiguity.py --force "${clutter[@]}" --split clutter --out "$T/clutter.md" \
  --title "Clutter (8 real YCB-V meshes, Kinect model): ours' wrong estimates, search miss or ambiguous"
mapfile -t ycbv < <(default_runs "$OUT/real/ycbv-gt_model/ours"); need "$OUT/real" "${ycbv[*]:-}"
"$PY" experiments/_lib/ambiguity.py --force "${ycbv[@]}" --split ycbv --out "$T/ycbv.md" \
  --title "Shared real YCB-V frames: ours' wrong estimates, search miss or ambiguous"
own=$(ls -dt "$OUT"/synthetic-gt_model/ours/seed0-+row=ours-* 2>/dev/null | head -1); need "$OUT" "$own"
"$PY" experiments/_lib/ambiguity.py --force "$own" --out "$T/embedded_own.md" \
  --title "Embedded set, own model: ours' wrong estimates, search miss or ambiguous"
cat=$(ls -dt "$OUT"/synthetic-templates/ours/seed0-+row=ours,protocol.max_templates=null-* 2>/dev/null | head -1); need "$OUT" "$cat"
"$PY" experiments/_lib/ambiguity.py --force "$cat" --out "$T/embedded_templates.md" \
  --title "Embedded set, 3 category templates (every registration): wrong estimates, search miss or ambiguous"
