"""The templates tables with the chosen, oracle and random-template errors side by side, for every
method, number of templates K and choice rule (``python experiments/_lib/category_table.py``; was
``experiments/_lib/category_table.py``): the paper's K-template tables and the template choice's development tables.

For a run of the ``templates`` protocol (each view registered to each of K templates):

- *chosen*: the registration the rule keeps without ground truth (the run's own ``choice``; any
  rules of :data:`catpose.methods.choice_rules.RULES` with ``--choices``, at the run's weights);
- *oracle*: the lowest error over the K registrations (the paper's "minimum error across
  templates"; it needs ground truth);
- *random*: a template drawn uniformly at random, as expected statistics: every registration of
  every view pooled (K rows per view, so each view weighs alike).

Errors are the run's recomputed ones (:func:`catpose.bench.report.runs.load_run`); a failed registration
counts 180 degrees. With K = 1 the three coincide::

    python experiments/_lib/category_table.py outputs/modelnet40_resampled-templates --category chair \
        --out results/category/chair.md
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from catpose.bench.scoring.curves import scored_errors
from catpose.errors import CatposeError, ConfigError

STATS = ("mean", "median", "acc10", "acc30")


def has_turns(group) -> bool:
    """Whether any row of ``group`` (rows of ``samples.jsonl``) carries ``info["turns"]``."""
    return "info" in group and any(isinstance(i, dict) and i.get("turns") for i in group["info"])


def error_stats(err: np.ndarray) -> dict[str, float]:
    """Mean and median (degrees) and the fractions under 10 and 30 degrees of ``err`` (n,)."""
    err = np.asarray(err, float)
    if err.size == 0:
        return {k: float("nan") for k in STATS}
    return {
        "mean": float(err.mean()),
        "median": float(np.median(err)),
        "acc10": float((err < 10).mean()),
        "acc30": float((err < 30).mean()),
    }


def rule_of(run):
    """The rule and weights (:class:`~catpose.methods.choice_rules.ChoiceRule`) a templates run keeps
    its views by: its ``config.yaml``'s ``choice`` group, or its protocol's old ``choice`` key; the
    ``score`` rule when it names none (predictions scored from files)."""
    from catpose.bench.run.build import build_protocol
    from catpose.methods.choice_rules import ChoiceRule

    config = getattr(run, "config", None) or {}
    protocol = config.get("protocol")
    if isinstance(protocol, dict) and protocol.get("_target_"):
        return build_protocol(config).choice
    return ChoiceRule(rule=str(protocol.get("choice", "score")) if isinstance(protocol, dict) else "score")


def run_rows(run, category: str | None, choices: Sequence[str]) -> list[dict]:
    """One row per choice rule for a templates run: ``K``, ``views``, ``choice`` and ``chosen_*``,
    ``oracle_*``, ``random_*`` statistics (:data:`STATS`). When K = 1, one row: choice ``-`` (the
    registration's own estimate), or the run's own turn rule where the run stored the turns
    (``choice.one_template_turns``). Each rule weighs as the run's ``choice`` group does."""
    import dataclasses

    from catpose.bench.protocols.absolute import Templates, absolute_gt_only
    from catpose.methods.choice_rules import TURN_RULES

    samples = absolute_gt_only(run.samples)
    if category is not None:
        samples = samples[samples["category"].astype(str) == category]
    if len(samples) == 0:
        return []
    sizes = samples.groupby("group_id").size()
    K = max(int(sizes.max()), templates_per_view(samples))
    incomplete = int((sizes < K).sum())  # views registered to fewer than their K templates (a limit, a kill)
    out = []
    run_rule = rule_of(run)
    own_rule = run_rule.rule
    choices = list(choices) or [own_rule]  # none named: the run's own
    one_template_turns = K == 1 and own_rule in TURN_RULES and has_turns(samples)
    if K > 1:
        rules = list(choices)
    else:  # one template: nothing to choose, unless between the estimate and its stored turns
        rules = [own_rule] if one_template_turns else list(choices[:1])
    for choice in rules:
        units = Templates(choice=dataclasses.replace(run_rule, rule=choice)).best_per_view(samples)
        row = {"K": K, "views": len(units), "choice": choice if K > 1 or one_template_turns else "-"}
        row["incomplete_views"] = incomplete
        row.update({f"chosen_{k}": v for k, v in error_stats(scored_errors(units)).items()})
        row.update({f"oracle_{k}": v for k, v in error_stats(units["oracle_err_deg"].to_numpy(float)).items()})
        row.update({f"random_{k}": v for k, v in error_stats(scored_errors(samples)).items()})
        out.append(row)
    return out


def templates_per_view(samples) -> int:
    """The K a templates run registered each view to, as its rows record it: the number of
    templates each estimate was checked on (``info.cross_costs``, one cost per template of the
    view; stored when K > 1); 0 when no row says."""
    counts = [len(i["cross_costs"]) for i in samples.get("info", []) if isinstance(i, dict) and i.get("cross_costs")]
    return max(counts, default=0)


def notes(rows: list[dict], runs_incomplete: Sequence[str] = ()) -> list[str]:
    """What the table's figures leave out: views registered to fewer templates than their K (one
    line per method and K), and runs that did not finish."""
    out: dict[tuple, str] = {}
    for r in rows:
        if r.get("incomplete_views"):
            out[(r["method"], r["K"])] = (
                f"{r['method']} (K = {r['K']}): {r['incomplete_views']} of {r['views']} views were registered to "
                f"fewer than {r['K']} templates (an incomplete run: limit=, or stopped); their chosen and oracle "
                "errors are over the templates they have"
            )
    return list(out.values()) + [f"Incomplete: {why}" for why in dict.fromkeys(runs_incomplete)]


def run_dirs(paths: Sequence[str | Path]) -> list[Path]:
    """Run directories: given directly, found below a folder, or the jobs of a sweep directory
    (``<output_root>/multirun/<name>/...``, read from its ``job.json`` files)."""
    from catpose.bench.report.runs import find_run_dirs
    from catpose.bench.run.sweep import JOB_FILE, read_sweep

    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir() and any(p.rglob(JOB_FILE)):
            sweeps = sorted({q.parent.parent for q in p.rglob(JOB_FILE)})
            out += [Path(j["run_dir"]) for s in sweeps for j in read_sweep(s) if j.get("run_dir")]
        else:
            out += find_run_dirs([p])
    return list(dict.fromkeys(out))


def build(
    paths: Sequence[str | Path], category: str | None, choices: Sequence[str], incomplete: list[str] | None = None
) -> list[dict]:
    """Rows for every templates run below ``paths`` (others are skipped), sorted by K then label;
    ``incomplete`` (a list, optional) receives why a run did not finish, for each such run."""
    from catpose.bench.report.labels import run_labels
    from catpose.bench.report.runs import load_run
    from catpose.methods.choice_rules import check_rule

    for c in choices:
        check_rule(c)
    runs = [r for r in (load_run(p) for p in run_dirs(paths)) if r.protocol == "templates"]
    if not runs:
        raise ConfigError(f"no run of protocol=templates below {', '.join(map(str, paths))}")

    def K_of(run) -> str:  # runs are labelled apart only within one K
        s = run.samples
        return str(max(int(s.groupby("group_id").size().max()), templates_per_view(s))) if len(s) else "0"

    if incomplete is not None:
        incomplete += [r.incomplete for r in runs if r.incomplete]
    rows = []
    for run, label in zip(runs, run_labels(runs, group_of=K_of)):
        for r in run_rows(run, category, choices):
            rows.append({"method": label, **r})
    if not rows and category is not None:
        have = sorted({str(c) for r in runs for c in r.samples.get("category", [])})
        raise ConfigError(f"--category {category}: no templates run here has it; they have {', '.join(have) or 'none'}")
    order = {c: i for i, c in enumerate(choices)}
    return sorted(rows, key=lambda r: (r["K"], r["method"], order.get(r["choice"], -1)))


def to_markdown(rows: list[dict], title: str = "", notes_: Sequence[str] = ()) -> str:
    """A Markdown table: K, method, choice, then chosen | oracle | random mean / median / @10 / @30;
    ``notes_`` (:func:`notes`) below it."""
    head = ["K", "method", "choice", "views"] + [
        f"{w} {s}" for w in ("chosen", "oracle", "random") for s in ("mean", "median", "@10", "@30")
    ]
    lines = ([f"**{title}**", ""] if title else []) + [
        "| " + " | ".join(head) + " |",
        "|" + "|".join(["---"] * 4 + ["---:"] * 12) + "|",
    ]
    for r in rows:
        cells = [str(r["K"]), r["method"], r["choice"], str(r["views"])]
        for w in ("chosen", "oracle", "random"):
            cells += [
                f"{r[f'{w}_mean']:.2f}",
                f"{r[f'{w}_median']:.2f}",
                f"{r[f'{w}_acc10']:.3f}",
                f"{r[f'{w}_acc30']:.3f}",
            ]
        lines.append("| " + " | ".join(cells) + " |")
    if notes_:
        lines += [""] + [f"Note: {n}" for n in notes_]
    return "\n".join(lines) + "\n"


def to_csv(rows: list[dict]) -> str:
    import pandas as pd

    df = pd.DataFrame(rows)
    if "incomplete_views" in df and not df["incomplete_views"].any():  # the column is there when it says something
        df = df.drop(columns="incomplete_views")
    return df.to_csv(index=False, float_format="%.4f")


def main(argv: list[str] | None = None) -> int:
    """``category_table.py RUN_OR_FOLDER... [--category C] [--choices fused,cross,score]
    [--format md|csv] [--out FILE]``; a user error is one line on stderr, exit status 2."""
    try:
        return _main(argv)
    except CatposeError as e:
        print(f"category_table: error: {e}", file=sys.stderr)
        return 2


def _main(argv: list[str] | None) -> int:
    ap = argparse.ArgumentParser(prog="category_table.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help="run directories or folders holding them (templates protocol)")
    ap.add_argument("--category", default=None, help="only this category (default: all rows pooled)")
    ap.add_argument(
        "--choices", default="", help="comma-separated choice rules (default: the rule each run kept its views by)"
    )
    ap.add_argument("--format", choices=("md", "csv"), default="md")
    ap.add_argument("--title", default="")
    from catpose.bench.run.overwrite import Output, add_output_options, input_runs

    add_output_options(ap, "write here instead of printing (a new file; see --force)", required=False)
    args = ap.parse_args(argv)
    out = Output(args.out, "file", input_runs(args.paths), args.force) if args.out else None  # before any work
    incomplete: list[str] = []
    rows = build(args.paths, args.category, [c.strip() for c in args.choices.split(",") if c.strip()], incomplete)
    said = notes(rows, incomplete)
    for line in said:  # on stderr too: a CSV has no place for them
        print(f"category_table: warning: {line}", file=sys.stderr)
    text = to_markdown(rows, args.title, said) if args.format == "md" else to_csv(rows)
    if out is not None:
        from catpose import atomic

        with out.writing() as path:
            atomic.write_text(path, text)
        print(f"wrote {len(rows)} rows to {args.out}")
    else:
        print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
