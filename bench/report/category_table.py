"""``bench category``: the templates tables with the chosen, oracle and random-template errors
side by side, for every method, number of templates K and choice rule.

For a run of the ``templates`` protocol (each view registered to each of K templates):

- *chosen*: the registration the rule keeps without ground truth (the run's ``choice`` weights;
  every rule of :data:`catpose.methods.choice_rules.RULES` with ``--choices``);
- *oracle*: the lowest error over the K registrations (the paper's "minimum error across
  templates"; it needs ground truth);
- *random*: a template drawn uniformly at random, as expected statistics: every registration of
  every view pooled (K rows per view, so each view weighs alike).

Errors are the run's recomputed ones (:func:`catpose.bench.report.runs.load_run`); a failed registration
counts 180 degrees. With K = 1 the three coincide::

    bench category outputs/modelnet40_resampled-templates --category chair --out results/category/chair.md
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from catpose.errors import CatposeError, ConfigError

STATS = ("mean", "median", "acc10", "acc30")


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


def row_errors(rows) -> np.ndarray:
    """(n,) each row's error in degrees, a failed row (or one without an error) counting 180."""
    import pandas as pd

    from catpose.bench.scoring.metrics import FAILED_ERROR_DEG

    err = pd.to_numeric(rows["err_deg"], errors="coerce").to_numpy(float)
    return np.where((rows["status"] != "ok").to_numpy() | ~np.isfinite(err), FAILED_ERROR_DEG, err)


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
    from catpose.bench.protocols.template_rows import has_turns
    from catpose.methods.choice_rules import TURN_RULES

    samples = absolute_gt_only(run.samples)
    if category is not None:
        samples = samples[samples["category"].astype(str) == category]
    if len(samples) == 0:
        return []
    K = int(samples.groupby("group_id").size().max())
    out = []
    run_rule = rule_of(run)
    own_rule = run_rule.rule
    one_template_turns = K == 1 and own_rule in TURN_RULES and has_turns(samples)
    if K > 1:
        rules = list(choices)
    else:  # one template: nothing to choose, unless between the estimate and its stored turns
        rules = [own_rule] if one_template_turns else list(choices[:1])
    for choice in rules:
        units = Templates(choice=dataclasses.replace(run_rule, rule=choice)).best_per_view(samples)
        row = {"K": K, "views": len(units), "choice": choice if K > 1 or one_template_turns else "-"}
        row.update({f"chosen_{k}": v for k, v in error_stats(row_errors(units)).items()})
        row.update({f"oracle_{k}": v for k, v in error_stats(units["oracle_err_deg"].to_numpy(float)).items()})
        row.update({f"random_{k}": v for k, v in error_stats(row_errors(samples)).items()})
        out.append(row)
    return out


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


def build(paths: Sequence[str | Path], category: str | None, choices: Sequence[str]) -> list[dict]:
    """Rows for every templates run below ``paths`` (others are skipped), sorted by K then label."""
    from catpose.bench.report.labels import run_labels
    from catpose.bench.report.runs import load_run
    from catpose.methods.choice_rules import check_rule

    for c in choices:
        check_rule(c)
    runs = [r for r in (load_run(p) for p in run_dirs(paths)) if r.protocol == "templates"]
    if not runs:
        raise ConfigError(f"no run of protocol=templates below {', '.join(map(str, paths))}")

    def K_of(run) -> str:  # runs are labelled apart only within one K
        return str(int(run.samples.groupby("group_id").size().max())) if len(run.samples) else "0"

    rows = []
    for run, label in zip(runs, run_labels(runs, group_of=K_of)):
        for r in run_rows(run, category, choices):
            rows.append({"method": label, **r})
    order = {c: i for i, c in enumerate(choices)}
    return sorted(rows, key=lambda r: (r["K"], r["method"], order.get(r["choice"], -1)))


def to_markdown(rows: list[dict], title: str = "") -> str:
    """A Markdown table: K, method, choice, then chosen | oracle | random mean / median / @10 / @30."""
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
    return "\n".join(lines) + "\n"


def to_csv(rows: list[dict]) -> str:
    import pandas as pd

    return pd.DataFrame(rows).to_csv(index=False, float_format="%.4f")


def main(argv: list[str] | None = None) -> int:
    """``bench category RUN_OR_FOLDER... [--category C] [--choices score,density,agreement]
    [--format md|csv] [--out FILE]``."""
    ap = argparse.ArgumentParser(prog="bench category", description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help="run directories or folders holding them (templates protocol)")
    ap.add_argument("--category", default=None, help="only this category (default: all rows pooled)")
    ap.add_argument("--choices", default="score", help="comma-separated choice rules (default: score)")
    ap.add_argument("--format", choices=("md", "csv"), default="md")
    ap.add_argument("--title", default="")
    ap.add_argument("--out", default=None, help="write here instead of printing")
    args = ap.parse_args(argv)
    try:
        rows = build(args.paths, args.category, [c.strip() for c in args.choices.split(",") if c.strip()])
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = to_markdown(rows, args.title) if args.format == "md" else to_csv(rows)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text)
        print(f"wrote {len(rows)} rows to {args.out}")
    else:
        print(text, end="")
    return 0
