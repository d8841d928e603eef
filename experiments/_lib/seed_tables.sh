# shellcheck shell=bash
# Sourced by the studies' make.sh: seed_tables OUT RESULTS writes one `bench table` per category-templates
# part a study ran (OUT/templates: the embedded set, seeds 1-3; OUT/ycbv_templates: YCB-V scene 1, seeds
# 0-2) to RESULTS/templates.md and RESULTS/ycbv_templates.md, a column per run folder `<variant>-seed<n>`.
# A part the study did not run is skipped.
seed_tables() {
  local out=$1 results=$2 set sub file title d
  for set in "templates:templates.md:the embedded set, development seeds 1-3" \
    "ycbv_templates:ycbv_templates.md:YCB-V scene 1 (dev), seeds 0-2"; do
    IFS=: read -r sub file title <<< "$set"
    [ -d "$out/$sub" ] || continue
    local dirs=() labels=()
    for d in "$out/$sub"/*-seed*; do
      dirs+=("$d")
      labels+=(--label "$(dirname "$(find "$d" -name samples.jsonl | head -1)")=$(basename "$d")")
    done
    .venv/bin/bench table --force "${dirs[@]}" "${labels[@]}" --layout generic --categories all --allow-mixed \
      --metrics n,mean,median,acc10,acc30 --out "$results/$file" \
      --title "Ours on $title, category templates (protocol templates)"
  done
}
