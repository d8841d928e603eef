"""Ours' selection breadth on development runs: for each value of a setting swept over runs of the
same views (``--key``, e.g. ``method.selection.top_k``, how many of ours' candidates its point rule
expands by their half turns and refines), the kept estimates' mean error, @30 and the oracle's mean,
on the instances that chose the setting and on those that only confirm it (``--split-at``: the first
instance id of the confirming part), with the median seconds per registration.

    .venv/bin/python experiments/selection_breadth/selection_grid.py OUT/multirun/airplanes_top_k \
        --key method.selection.top_k --split-at airplane_8040 --out results/category/dev/....md

Reads the runs' files only (the kept estimate is the run's own ``choice`` rule; with K = 1 the
registration's own estimate, and the oracle is the same). Written by
experiments/selection_breadth/make_selection_dev.sh.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "category_choice"))
from top_weight_grid import set_runs, sweeps_parser  # noqa: E402  (the template choice study's grid helpers)


def setting(config: dict, key: str):
    """The value at the dotted ``key`` of a run's resolved ``config`` (None where it is absent)."""
    node = config
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def view_table(run):
    """(instance ids (V,), kept errors (V,), oracle errors (V,), seconds per registration (R,)) of a
    templates run, one entry per view, under the run's own choice rule."""
    import pandas as pd

    from catpose.bench.protocols.absolute import absolute_gt_only
    from catpose.bench.report.runs import protocol_of
    from catpose.bench.scoring.curves import scored_errors

    samples = absolute_gt_only(run.samples)
    kept = protocol_of(run).best_per_view(samples)
    seconds = pd.to_numeric(samples["runtime_s"], errors="coerce").to_numpy(float)
    return (
        kept["instance_id"].astype(str).to_numpy(),
        scored_errors(kept),
        kept["oracle_err_deg"].to_numpy(float),
        seconds,
    )


def part_stats(errors: np.ndarray) -> str:
    """``mean | @30`` of errors (degrees) as table cells."""
    return f"{errors.mean():.2f} | {np.mean(errors < 30.0):.3f}" if len(errors) else "- | -"


def main(argv: list[str] | None = None) -> int:
    from catpose.atomic import write_text

    ap = sweeps_parser(__doc__, "Development runs")
    ap.add_argument("--key", required=True, help="the dotted config key the sweep varies")
    ap.add_argument("--split-at", help="first instance id of the confirming part (ids sort as strings)")
    args = ap.parse_args(argv)
    rows = []
    for order, sweep in enumerate(args.sweeps):
        for run in set_runs(sweep):
            ids, kept, oracle, seconds = view_table(run)
            chose = ids < args.split_at if args.split_at else np.ones(len(ids), bool)
            value = setting(run.config, args.key)
            by = (run.method, float(value) if isinstance(value, (int, float)) else str(value), order)
            rows.append((by, (run.method, value, Path(sweep).name, kept, oracle, chose, seconds)))
    rows = [row for _, row in sorted(rows, key=lambda r: r[0])]
    split, sets = bool(args.split_at), len(args.sweeps) > 1
    head = (
        ["method", args.key]
        + (["runs"] if sets else [])
        + ["views"]
        + (["chose: mean", "chose: @30", "confirm: mean", "confirm: @30"] if split else [])
        + ["all: mean", "all: median", "all: @30", "oracle mean", "median s"]
    )
    lines = [
        f"**{args.title}: the kept estimates by `{args.key}`"
        + (f"; chose: instances before {args.split_at}, confirm: from it" if split else "")
        + ("; mean over runs: the runs' means averaged" if sets else "")
        + "**",
        "",
        "| " + " | ".join(head) + " |",
        "|---|---|" + ("---|" if sets else "") + "---:|" * (len(head) - 2 - sets),
    ]
    for i, (method, value, name, kept, oracle, chose, seconds) in enumerate(rows):
        cells = [method, str(value)] + ([name] if sets else []) + [str(len(kept))]
        if split:
            cells += [part_stats(kept[chose]), part_stats(kept[~chose])]
        cells += [
            f"{kept.mean():.2f}",
            f"{np.median(kept):.2f}",
            f"{np.mean(kept < 30.0):.3f}",
            f"{oracle.mean():.2f}",
            f"{np.nanmedian(seconds):.3f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
        last = i + 1 == len(rows) or rows[i + 1][:2] != (method, value)
        if sets and last:
            same = [r for r in rows if r[:2] == (method, value)]
            lines.append(
                f"| {method} | {value} | mean over runs | {sum(len(r[3]) for r in same)} | "
                + ("- | - | - | - | " if split else "")
                + f"{np.mean([r[3].mean() for r in same]):.2f} | - | {np.mean([np.mean(r[3] < 30.0) for r in same]):.3f} | "
                + f"{np.mean([r[4].mean() for r in same]):.2f} | - |"
            )
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {len(rows)} rows to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
