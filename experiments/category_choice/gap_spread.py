"""How far an 8-view chair table's chosen mean can stand from its oracle by chance: the spread of
the gap (chosen mean error less the oracle's, degrees) over view sets drawn like the paper table's
(2 test chairs x 4 views) from development runs, under one choice rule.

    .venv/bin/python experiments/category_choice/gap_spread.py OUT/multirun/chair_dev_k3 \
        OUT/multirun/chair_dev_swap{0,1,2,3} --row ours --out results/category/dev/chair_dev_gap_spread.md

Per template set (one sweep) and method row: each view's gap under ``--choice`` (default
``cross_top_turns``; for it, only the turns in ``--turns`` are read, default the protocol's
90 and 270), then ``--draws`` draws (seeded) of ``--chairs`` test chairs without replacement and
``--views`` of each one's views without replacement; a draw's gap is the mean over its views. Views
of one chair are drawn together because they are not independent. Reads the runs' stored costs
(no registration is run). Written by experiments/category_choice/make_chair_dev.sh and
make_chair_procedural.sh.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from top_weight_grid import set_runs, sweeps_parser, with_turns  # noqa: E402  (the sibling development script)


def view_gaps(samples, choice: str, turns: tuple[float, ...]):
    """(instance ids, gaps): per view of one template run's rows, the chosen error less the
    oracle's (degrees), by the view's instance."""
    from catpose.bench.protocols.absolute import Templates
    from catpose.bench.scoring.curves import scored_errors
    from catpose.methods.choice_rules import TURN_RULES

    views = Templates(choice=choice).best_per_view(with_turns(samples, turns) if choice in TURN_RULES else samples)
    gaps = np.asarray(scored_errors(views), float) - views["oracle_err_deg"].to_numpy(float)
    return views["instance_id"].astype(str).to_numpy(), gaps


def drawn_gaps(
    inst: np.ndarray, gaps: np.ndarray, chairs: int, views: int, draws: int, rng: np.random.Generator
) -> np.ndarray:
    """(draws,) mean gap of ``chairs`` instances x ``views`` views each, drawn without replacement
    (instances with fewer views than ``views`` are not drawn)."""
    by = {i: gaps[inst == i] for i in np.unique(inst)}
    names = sorted(i for i, g in by.items() if len(g) >= views)
    if len(names) < chairs:
        raise SystemExit(f"gap_spread: only {len(names)} instances have {views} views; need {chairs}")
    out = np.empty(draws)
    for d in range(draws):
        picked = rng.choice(len(names), chairs, replace=False)
        out[d] = np.mean([rng.choice(by[names[p]], views, replace=False) for p in picked])
    return out


def main(argv: list[str] | None = None) -> int:
    from catpose.atomic import write_text
    from catpose.bench.protocols.absolute import absolute_gt_only

    ap = sweeps_parser(__doc__)
    ap.add_argument("--row", action="append", help="method rows to read (default: all)")
    ap.add_argument("--choice", default="cross_top_turns")
    ap.add_argument("--turns", default="90,270", help="turned candidates the rule reads (degrees)")
    ap.add_argument("--chairs", type=int, default=2)
    ap.add_argument("--views", type=int, default=4)
    ap.add_argument("--draws", type=int, default=10000)
    ap.add_argument("--threshold", type=float, default=10.0, help="the gap a target allows (degrees)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    turns = tuple(float(t) for t in args.turns.split(",") if t.strip())
    rng = np.random.default_rng(args.seed)
    lines = [
        f"**{args.title}: gap of `{args.choice}` to the oracle (chosen mean less oracle mean, degrees) "
        f"over {args.draws} draws of {args.chairs} chairs x {args.views} views per template set**",
        "",
        "| method | set | views | gap, all views | draws: median | draws: 90th pct | "
        f"draws: share over {args.threshold:g} |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s, sweep in enumerate(args.sweeps, 1):
        for run in set_runs(sweep):
            if args.row and run.method.lower() not in [r.lower() for r in args.row]:
                continue
            inst, gaps = view_gaps(absolute_gt_only(run.samples), args.choice, turns)
            d = drawn_gaps(inst, gaps, args.chairs, args.views, args.draws, rng)
            lines.append(
                f"| {run.method} | {s} | {len(gaps)} | {gaps.mean():.2f} | {np.median(d):.2f} | "
                f"{np.percentile(d, 90):.2f} | {np.mean(d > args.threshold):.3f} |"
            )
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {len(lines) - 4} rows to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
