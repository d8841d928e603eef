"""The ``cross_top_turns`` rule with one template, on the procedural airplanes: for each turn set
and top-offset weight, each method's mean error with the rule against the registration's own
estimate, on the airplanes that chose the setting and on those that only confirm it; then, for
the kept setting, the same per kind of airplane (where it gains and where it loses).

    .venv/bin/python experiments/category_choice/one_template_turns.py OUT/multirun/airplane_procedural_k1 \
        --alignment ROOT/alignment_airplane.csv --split-at airplane_8040 --keep "180@0.05" --out ...

Reads the runs' stored ``info.cross_costs``, ``info.top_offset`` and ``info.turns`` (no
registration is run). With one template the oracle is the registration's own estimate, so a gap
below 0 is what the turns gain. The kinds come from the ``note`` column that
the procedural dataset writes (``experiments/_lib/procedural.py``'s ``kinds``). Written by experiments/category_choice/make_airplane_procedural.sh.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from top_weight_grid import WEIGHTS, chosen_errors, parse_turn_sets  # noqa: E402  (sibling development script)


def main(argv: list[str] | None = None) -> int:
    from catpose.atomic import write_text
    from catpose.bench.protocols.absolute import absolute_gt_only
    from catpose.bench.report.runs import load_run

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
    from category_table import run_dirs  # experiments/_lib/category_table.py
    from procedural import kinds as kinds_of  # experiments/_lib/procedural.py

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sweep")
    ap.add_argument("--alignment", required=True, help="the root's alignment_airplane.csv (kinds)")
    ap.add_argument("--split-at", required=True, help="first instance id of the confirming part")
    ap.add_argument("--turn-sets", default="180;90,270;90,180,270")
    ap.add_argument("--weights", default=",".join(f"{w:g}" for w in WEIGHTS))
    ap.add_argument("--keep", required=True, help="the kept setting, TURNS@WEIGHT, e.g. 180@0.05")
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default="Procedural airplanes, one template")
    args = ap.parse_args(argv)
    kinds = kinds_of(Path(args.alignment))
    turn_sets = [t for t in parse_turn_sets(args.turn_sets) if t]
    weights = [float(w) for w in args.weights.split(",")]
    keep_turns, keep_weight = parse_turn_sets(args.keep.split("@")[0])[0], float(args.keep.split("@")[1])
    grid = [
        "| method | turns | weight | chose: mean | chose: @30 | chose: gain | confirm: mean | confirm: @30 | confirm: gain |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    per_kind = [
        "| method | kind | views | own estimate: mean | own estimate: @30 | kept: mean | kept: @30 |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    counts = {}
    for run in sorted((load_run(p) for p in run_dirs([args.sweep])), key=lambda r: r.method):
        samples = absolute_gt_only(run.samples).sort_values("group_id").reset_index(drop=True)
        # one row per view (K = 1), so the views' errors below line up with ``instance``
        instance = samples["group_id"].str.split("/").str[1].to_numpy()
        parts = {"chose": instance < args.split_at, "confirm": instance >= args.split_at}
        counts = {k: int(m.sum()) for k, m in parts.items()}
        base = chosen_errors(samples, (), 0.0)
        cells = [f"{base[m].mean():.2f} | {np.mean(base[m] < 30):.3f} | - " for m in parts.values()]
        grid.append(f"| {run.method} | none | - | " + " | ".join(cells) + " |")
        errors = {(turns, w): chosen_errors(samples, turns, w) for turns in turn_sets for w in weights}
        for (turns, w), e in errors.items():
            cells = [
                f"{e[m].mean():.2f} | {np.mean(e[m] < 30):.3f} | {e[m].mean() - base[m].mean():.2f}"
                for m in parts.values()
            ]
            grid.append(f"| {run.method} | {','.join(f'{t:g}' for t in turns)} | {w:g} | " + " | ".join(cells) + " |")
        kept = errors.get((keep_turns, keep_weight))
        kept = chosen_errors(samples, keep_turns, keep_weight) if kept is None else kept
        kind = np.array([kinds.get(i, "?") for i in instance])
        for name in sorted(set(kind)):
            m = kind == name
            per_kind.append(
                f"| {run.method} | {name} | {m.sum()} | {base[m].mean():.2f} | {np.mean(base[m] < 30):.3f} | "
                f"{kept[m].mean():.2f} | {np.mean(kept[m] < 30):.3f} |"
            )
    head = (
        f"**{args.title}: mean error (degrees) and @30 of `cross_top_turns` over the estimate and its turns, "
        f"against the registration's own estimate (gain: the difference); chose: the {counts.get('chose', 0)} views "
        f"before {args.split_at}, confirm: the {counts.get('confirm', 0)} from it**"
    )
    kind_head = (
        f"**{args.title}, by kind, all views: the registration's own estimate against the kept setting "
        f"(turns {args.keep.split('@')[0]}, weight {keep_weight:g})**"
    )
    write_text(Path(args.out), "\n".join([head, "", *grid, "", kind_head, "", *per_kind]) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
