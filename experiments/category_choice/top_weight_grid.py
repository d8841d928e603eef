"""The ``cross_top`` rule's top-offset weight on the chair development runs: for each weight, each
method's chosen mean error less the oracle's, per template set and averaged over the sets; with
``--turn-sets``, also for the ``cross_top_turns`` rule over each set of the turned candidates the
runs stored.

    .venv/bin/python experiments/category_choice/top_weight_grid.py OUT/multirun/chair_dev_k3 \
        OUT/multirun/chair_dev_swap{0,1,2,3} --out results/category/dev/chair_dev_top_weight.md
    .venv/bin/python experiments/category_choice/top_weight_grid.py OUT/multirun/procedural_k3_turns \
        --turn-sets "none;90,270;90,180,270" --out ...

Reads the runs' stored ``info.cross_costs``, ``info.top_offset`` and ``info.turns`` (no
registration is run); weight 0 without turns is the ``cross`` rule. The oracle is the best of the
K registrations' own estimates, so with turns the gap can fall below 0. Written by
experiments/category_choice/make_chair_dev.sh and make_chair_procedural.sh.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

WEIGHTS = (0.0, 0.025, 0.05, 0.075, 0.1, 0.15, 0.2)


def with_turns(samples, turns: tuple[float, ...]):
    """``samples`` whose rows keep only the turned candidates at ``turns`` (degrees)."""
    samples = samples.copy()
    samples["info"] = [
        {**i, "turns": [t for t in i.get("turns", []) if t["turn_deg"] in turns]} if isinstance(i, dict) else i
        for i in samples["info"]
    ]
    return samples


def chosen_errors(samples, turns: tuple[float, ...] | None, weight: float) -> np.ndarray:
    """(V,) the error (degrees) of each view's row, in ``group_id`` order, that ``cross_top`` keeps
    among ``samples`` (one template run's rows) when it weighs the top offset ``weight``; with
    ``turns``, that the ``cross_top_turns`` rule keeps over those turned candidates. With one
    template and no turns: each view's own estimate."""
    import pandas as pd

    from catpose.bench.protocols.absolute import choose_row
    from catpose.bench.scoring.curves import scored_errors
    from catpose.methods.choice_rules import ChoiceRule

    rule = ChoiceRule(rule="cross_top" if not turns else "cross_top_turns").with_offset_weight(weight)
    rows = samples if not turns else with_turns(samples, turns)
    chosen = pd.DataFrame([choose_row(g, rule) for _, g in rows.groupby("group_id")])
    return np.asarray(scored_errors(chosen), float)


def gap(samples, weight: float, turns: tuple[float, ...] | None = None) -> float:
    """The chosen mean error (:func:`chosen_errors`) less the oracle's (degrees) over the views of
    ``samples``."""
    from catpose.bench.protocols.absolute import Templates

    oracle = Templates(choice="cross").best_per_view(samples)["oracle_err_deg"].to_numpy(float)
    return float(chosen_errors(samples, turns, weight).mean() - oracle.mean())


def parse_turn_sets(text: str) -> list[tuple[float, ...]]:
    """``"none;90,270"`` -> [(), (90.0, 270.0)]."""
    return [() if part.strip() == "none" else tuple(float(x) for x in part.split(",")) for part in text.split(";")]


def sweeps_parser(doc: str, title: str = "Chair development runs") -> argparse.ArgumentParser:
    """The development grids' common arguments: one sweep directory per template set, ``--out``
    (the table written) and ``--title`` (what the runs are); ``doc``: the script's docstring."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("sweeps", nargs="+", help="one sweep directory per template set")
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default=title, help="what the runs are")
    return ap


def set_runs(sweep: str | Path) -> list:
    """The runs (:func:`catpose.bench.report.runs.load_run`) of one sweep directory, by method name."""
    from catpose.bench.report.runs import load_run

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
    from category_table import run_dirs  # experiments/_lib/category_table.py

    return sorted((load_run(p) for p in run_dirs([sweep])), key=lambda r: r.method)


def main(argv: list[str] | None = None) -> int:
    from catpose.atomic import write_text
    from catpose.bench.protocols.absolute import absolute_gt_only

    ap = sweeps_parser(__doc__)
    ap.add_argument("--turn-sets", default="none", help="';'-separated sets of turns (degrees), 'none' for none")
    ap.add_argument("--weights", default=",".join(f"{w:g}" for w in WEIGHTS), help="','-separated top-offset weights")
    args = ap.parse_args(argv)
    turn_sets = parse_turn_sets(args.turn_sets)
    weights = tuple(float(w) for w in args.weights.split(","))
    gaps: dict[tuple[str, tuple], list[list[float]]] = {}
    for sweep in args.sweeps:
        for run in set_runs(sweep):
            samples = absolute_gt_only(run.samples)
            for turns in turn_sets:
                gaps.setdefault((run.method, turns), []).append([gap(samples, w, turns) for w in weights])
    sets = len(args.sweeps)
    show_turns = turn_sets != [()]
    lines = [
        f"**{args.title}: chosen mean error less the oracle's (degrees) by the top-offset "
        f"weight of `cross_top` ({sets} template sets; weight 0 is `cross`)**",
        "",
        "| method | "
        + ("turns | " if show_turns else "")
        + "weight | "
        + " | ".join(f"set {i + 1}" for i in range(sets))
        + " | mean over sets |",
        "|---|" + ("---|" if show_turns else "") + "---:|" + "---:|" * (sets + 1),
    ]
    if show_turns:
        lines[0] = lines[0][:-3] + "; turns: the `cross_top_turns` candidates, none: `cross_top`)**"
    for method, turns in sorted(gaps, key=lambda k: (k[0], turn_sets.index(k[1]))):
        g = np.asarray(gaps[(method, turns)], float)
        label = (",".join(f"{t:g}" for t in turns) or "none") + " | " if show_turns else ""
        for j, w in enumerate(weights):
            lines.append(
                f"| {method} | {label}{w:g} | " + " | ".join(f"{x:.2f}" for x in g[:, j]) + f" | {g[:, j].mean():.2f} |"
            )
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {len(lines) - 4} rows to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
