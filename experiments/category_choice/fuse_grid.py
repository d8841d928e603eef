"""The ``fused`` rule's agreement angle on development runs: for each angle, each method's chosen
mean error less the oracle's (degrees), per template set and averaged over the sets, beside
``cross_top_turns`` (the same choice, its pose not averaged).

    .venv/bin/python experiments/category_choice/fuse_grid.py OUT/multirun/procedural_k3_turns30 \
        --out results/category/dev/chair_procedural_fuse.md --title "Procedural chairs ..."

Only the turned candidates in ``--turns`` are read (default the protocol's 90 and 270, the chair
rule's). Both rules weigh the top offset as ``fused`` does (``FUSED_TOP_WEIGHT``), so the
``cross_top_turns`` row is the same choice unaveraged; with ``--weights``, each setting at each
of those weights instead (a ``weight`` column). Reads the runs' stored ``info.cross_costs``, ``info.top_offset`` and ``info.turns``
(no registration is run). The oracle is the best of the K registrations' own estimates, so a gap
below 0 is possible. Also written: for each angle, the mean number of poses averaged per view.
Written by experiments/category_choice/make_chair_dev.sh and make_chair_procedural.sh.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from top_weight_grid import set_runs, sweeps_parser, with_turns  # noqa: E402  (the sibling development script)

ANGLES = (10.0, 15.0, 20.0, 30.0)


def chosen(samples, fuse_deg: float | None, top_weight: float | None = None):
    """One row per view of ``samples`` (one template run's rows, turns already filtered), in
    ``group_id`` order: ``cross_top_turns``'s choice (top offset weighted ``top_weight``, the
    rule's own when None), averaged with the agreeing poses of the other templates within
    ``fuse_deg`` degrees (``fused``) unless None."""
    import pandas as pd

    from catpose.bench.protocols.absolute import choose_row
    from catpose.methods.choice_rules import ChoiceRule

    rule = ChoiceRule(rule="cross_top_turns" if fuse_deg is None else "fused").with_offset_weight(top_weight)
    if fuse_deg is not None:
        rule = dataclasses.replace(rule, agree_deg=float(fuse_deg))
    return pd.DataFrame([choose_row(g, rule) for _, g in samples.groupby("group_id")])


def main(argv: list[str] | None = None) -> int:
    from catpose.atomic import write_text
    from catpose.bench.protocols.absolute import Templates, absolute_gt_only
    from catpose.bench.scoring.curves import scored_errors
    from catpose.methods.choice_rules import FUSED_TOP_WEIGHT

    ap = sweeps_parser(__doc__)
    ap.add_argument("--turns", default="90,270", help="','-separated turns (degrees) read from the runs")
    ap.add_argument("--angles", default=",".join(f"{a:g}" for a in ANGLES), help="','-separated agreement angles")
    ap.add_argument(
        "--weights",
        default=None,
        help="','-separated top-offset weights (default: the fused rule's alone, no weight column)",
    )
    args = ap.parse_args(argv)
    turns = tuple(float(t) for t in args.turns.split(","))
    weights = [FUSED_TOP_WEIGHT] if args.weights is None else [float(w) for w in args.weights.split(",")]
    settings: list[tuple[float, float | None]] = [
        (w, a) for w in weights for a in [None] + [float(a) for a in args.angles.split(",")]
    ]
    gaps: dict[str, list[list[float]]] = {}
    fused: dict[str, list[list[float]]] = {}
    for sweep in args.sweeps:
        for run in set_runs(sweep):
            samples = with_turns(absolute_gt_only(run.samples), turns)
            oracle = Templates(choice="cross").best_per_view(samples)["oracle_err_deg"].to_numpy(float).mean()
            rows = [chosen(samples, a, w) for w, a in settings]
            gaps.setdefault(run.method, []).append([float(scored_errors(r).mean() - oracle) for r in rows])
            fused.setdefault(run.method, []).append(
                [float(np.mean([i.get("fused_templates", 1) for i in r["info"]])) for r in rows]
            )
    sets = len(args.sweeps)
    by_weight = args.weights is not None
    lines = [
        f"**{args.title}: chosen mean error less the oracle's (degrees) by the agreement angle of `fused` "
        + ("and the top-offset weight " if by_weight else f"at top-offset weight {FUSED_TOP_WEIGHT:g} ")
        + f"({sets} template sets; `cross_top_turns` is the same choice unaveraged; turns read: "
        f"{', '.join(f'{t:g}' for t in turns)}; poses: mean number averaged per view, over the sets)**",
        "",
        "| method | "
        + ("weight | " if by_weight else "")
        + "rule | angle | "
        + " | ".join(f"set {i + 1}" for i in range(sets))
        + " | mean over sets | poses |",
        "|---|" + ("---:|" if by_weight else "") + "---|---:|" + "---:|" * (sets + 2),
    ]
    for method in sorted(gaps):
        g, n = np.asarray(gaps[method], float), np.asarray(fused[method], float)
        for j, (w, a) in enumerate(settings):
            label = "cross_top_turns | -" if a is None else f"fused | {a:g}"
            label = f"{w:g} | {label}" if by_weight else label
            lines.append(
                f"| {method} | {label} | "
                + " | ".join(f"{x:.2f}" for x in g[:, j])
                + f" | {g[:, j].mean():.2f} | {n[:, j].mean():.2f} |"
            )
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {len(lines) - 4} rows to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
