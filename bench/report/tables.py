"""Paper tables from run directories (files only: ``samples.jsonl``, ``config.yaml``, ``run.json``).

A run directory is what the runner writes. Its per-sample rows are turned into scoring units by
the run's own protocol (``score_units``: templates keep the best-scored template per view,
``relative`` forms view pairs), summarized per category with :func:`catpose.bench.scoring.metrics.summarize`,
and laid out like the paper's tables:

==============  ================================================================================
layout          paper table
==============  ================================================================================
optimiser       \\compareoptimizerfull: pipeline/descriptor x method rows, category x {mean,
                median, L_T} columns
one_template    \\matchonetemplateplane: one category (airplane), {mean, median, @10, @30, L_T}
templates       \\templatechair: rows grouped by the number of templates (chair), oracle error
real            \\realdatatablesmall: category x metric rows, one column per method
tyol            \\TYOL: method x metric rows, one column per category (bottle ... mug)
ablation        \\ablationsvd: with and without optimisation, {mean, median, @10}
generic         any runs x categories x metrics
==============  ================================================================================

Best values are bold and second best underlined per column (or per row for ``real``), with the
direction of each metric (errors lower, accuracies higher). Output: Markdown, LaTeX or CSV.

Runs on BOP-layout data (YCB-V, TYO-L, ``dataset=clutter``) also get BOP'19's average recall and
its parts (``ar``, ``ar_vsd``, ``ar_mssd``, ``ar_mspd``) after the layout's own metrics, from the
per-target errors of ``bench score``'s code (:func:`catpose.bench.run.bop_ar.target_errors`).

Usage: ``bench table outputs/modelnet40-gt_model --layout optimiser --format latex``. (The layout
was spelt ``optimizer`` before; that name is refused with the new one named.)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from catpose.bench.report.labels import parse_labels, pipeline_label, run_labels, template_count
from catpose.bench.report.runs import Run, find_run_dirs, load_run, protocol_of, scored_units
from catpose.bench.report.table_format import METRICS, Metric, Table, metric, prune, to_csv, to_latex, to_markdown
from catpose.errors import ConfigError

# tables.load_run, tables.scored_units, tables.protocol_of, tables.to_markdown ... stay reachable here:
# reports and plots read runs and render tables through this module's names
__all__ = [
    "LAYOUTS",
    "build_table",
    "collect",
    "split_by_protocol",
    "load_run",
    "scored_units",
    "protocol_of",
    "find_run_dirs",
    "run_labels",
    "pipeline_label",
    "parse_labels",
    "to_markdown",
    "to_latex",
    "to_csv",
    "Run",
    "Table",
    "Metric",
    "METRICS",
]


RENDERERS: dict[str, Callable[[Table], str]] = {"md": to_markdown, "latex": to_latex, "csv": to_csv}


# --------------------------------------------------------------------------------------------
# Layouts


@dataclass
class Entry:
    """The runs sharing one row label, pooled: per-category statistics."""

    group: str
    label: str
    summary: Any  # DataFrame from metrics.summarize, indexed by category
    units: Any = None  # the pooled scoring units (DataFrame): statistics beyond the summary's (curves)
    bop: Any = None  # the pooled per-target BOP errors (DataFrame) of runs on BOP-layout data, or None


def collect(
    runs: Sequence[Run],
    group_of: Callable[[Run], str],
    labels: dict[str, str] | None = None,
    error_of: Callable[[Run], str] = lambda r: "err_deg",
    with_bop: bool = False,
) -> list[Entry]:
    """Pool the scoring units of runs with the same (group, label) and summarize per category.

    ``labels`` maps a run directory (as given, or its name) to a user label; labels are made
    unique within a group by :func:`run_labels`. ``error_of`` names the error column each run is
    scored by (see :func:`scored_units`). ``with_bop``: also pool the runs' per-target BOP errors
    (runs on BOP-layout data; :func:`catpose.bench.run.bop_ar.target_errors`).
    """
    import pandas as pd

    from catpose.bench.run.bop_ar import target_errors
    from catpose.bench.scoring.metrics import summarize

    pooled: dict[tuple[str, str], list] = {}
    bop: dict[tuple[str, str], list] = {}
    for run, label in zip(runs, run_labels(runs, labels, group_of)):
        key = (group_of(run), label)
        pooled.setdefault(key, []).append(scored_units(run, error_of(run)))
        errors = target_errors(run.path) if with_bop else None
        if errors is not None and len(errors):
            bop.setdefault(key, []).append(errors)
    entries = []
    for key, parts in pooled.items():
        units = pd.concat(parts, ignore_index=True)
        errors = pd.concat(bop[key], ignore_index=True) if key in bop else None
        entries.append(Entry(*key, summarize(units).set_index("category"), units, errors))
    return entries


def is_bop_run(run: Run) -> bool:
    """Whether a run is on BOP-layout data (its table rows can show BOP's AR)."""
    from catpose.bench.scoring.bop_rows import is_bop_layout

    return is_bop_layout(run.config.get("dataset"))


def _value(entry: Entry, category: str, key: str) -> float:
    """A summary statistic, or a threshold statistic (``acc5``, ``auc30``, ``5deg5cm``:
    :mod:`catpose.bench.scoring.curves`) of the entry's units of ``category`` (``all``: every unit)."""
    from catpose.bench.scoring.bop_rows import AR_KEYS

    if key in AR_KEYS:
        if entry.bop is None:
            return float("nan")
        from catpose.bench.scoring.bop_eval import metric_value

        errors = entry.bop if category == "all" else entry.bop[entry.bop["category"].astype(str) == category]
        return metric_value(errors, key) if len(errors) else float("nan")
    if key not in METRICS:
        from catpose.bench.scoring.curves import statistic

        if category not in entry.summary.index or entry.units is None:
            return float("nan")
        units = entry.units if category == "all" else entry.units[entry.units["category"].astype(str) == category]
        return statistic(units, key)
    col = METRICS[key].column
    if category not in entry.summary.index or col not in entry.summary.columns:
        return float("nan")
    return float(entry.summary.loc[category, col])


def _categories(
    entries: Sequence[Entry], wanted: Sequence[str] | None = None, defaults: Sequence[str] | None = None
) -> list[str]:
    """User-given categories as they are; else the layout's defaults that some run has; else
    every category present (sorted)."""
    if wanted:
        return list(wanted)
    seen: list[str] = []
    for e in entries:
        seen += [c for c in e.summary.index if c != "all" and c not in seen]
    chosen = [c for c in defaults or [] if c in seen]
    return chosen or sorted(seen)


def grid_table(
    entries: Sequence[Entry],
    categories: Sequence[str],
    metrics: Sequence[str],
    title: str,
    grouped: bool = True,
    group_header: str = "Pipeline / Descriptor",
) -> Table:
    """Rows (group, method) x columns (category, metric); ranks per column."""
    rows = [(e.group, e.label) if grouped else (e.label,) for e in entries]
    cols = [(c.capitalize(), metric(m).md) for c in categories for m in metrics]
    t = Table(title, [group_header, "Methods"] if grouped else ["Methods"], rows, cols)
    for e, r in zip(entries, rows):
        for c in categories:
            for m in metrics:
                t.cells[(r, (c.capitalize(), metric(m).md))] = (_value(e, c, m), m)
    return t


#: each layout's metrics when none are given (``--acc`` / ``--auc`` replace and add to them)
DEFAULT_METRICS: dict[str, list[str]] = {
    "generic": ["mean", "median", "acc10", "acc30", "trans"],
    "optimiser": ["mean", "median", "trans"],
    "one_template": ["mean", "median", "acc10", "acc30", "trans"],
    "templates": ["mean", "median", "acc10", "acc30"],
    "ablation": ["mean", "median", "acc10"],
    "real": ["mean", "median", "acc10", "acc30"],
    "tyol": ["mean", "median", "acc10", "acc30"],
}


def with_thresholds(metrics: Sequence[str], keys: Sequence[str]) -> list[str]:
    """``metrics`` with their ``acc<X>`` entries replaced by ``keys`` (``--acc``'s and
    ``--auc``'s), placed where the first accuracy was, else after ``median`` (else at the end)."""
    import re

    is_acc = [bool(re.fullmatch(r"acc\d+(\.\d+)?", m)) for m in metrics]
    if any(is_acc):
        pos = is_acc.index(True)
    else:
        pos = list(metrics).index("median") + 1 if "median" in metrics else len(metrics)
    kept = [m for m, a in zip(metrics, is_acc) if not a]
    pos -= sum(is_acc[:pos])
    return kept[:pos] + [k for k in keys if k not in kept] + kept[pos:]


def layout_generic(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = "Results",
) -> Table:
    cats = _categories(entries, categories) + ([] if categories else ["all"])
    return grid_table(
        entries,
        cats,
        metrics or DEFAULT_METRICS["generic"],
        title,
        grouped=any(e.group not in ("", "-") for e in entries),
    )


def layout_optimiser(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = None,
) -> Table:
    return grid_table(
        entries,
        _categories(entries, categories, ["airplane", "chair", "car"]),
        metrics or DEFAULT_METRICS["optimiser"],
        title or "Partial point cloud registration with the ground-truth complete shape",
    )


def layout_one_template(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = None,
) -> Table:
    return grid_table(
        entries,
        _categories(entries, categories, ["airplane"]),
        metrics or DEFAULT_METRICS["one_template"],
        title or "Registration with one category-level template (airplane)",
    )


def layout_templates(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = None,
) -> Table:
    return grid_table(
        entries,
        _categories(entries, categories, ["chair"]),
        metrics or DEFAULT_METRICS["templates"],
        title or "Registration with several category-level templates (chair)",
        group_header="Number of templates",
    )


def layout_ablation(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = None,
) -> Table:
    return grid_table(
        entries,
        _categories(entries, categories, ["airplane"]),
        metrics or DEFAULT_METRICS["ablation"],
        title or "Registration with and without the pose optimisation (airplane)",
        group_header="Setting",
    )


def layout_real(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = None,
) -> Table:
    """Rows (category, metric) x one column per method; ranks across methods within a row."""
    cats = _categories(entries, categories, ["airplane", "chair", "car"])
    metrics = metrics or DEFAULT_METRICS["real"]
    cols = [(e.label,) for e in entries]
    rows = [(c.capitalize(), metric(m).md) for c in cats for m in metrics]
    t = Table(
        title or "Pairwise relative pose between two partial views of real scans",
        ["Category", "Metric"],
        rows,
        cols,
        rank_by="row",
    )
    for e, col in zip(entries, cols):
        for c in cats:
            for m in metrics:
                t.cells[((c.capitalize(), metric(m).md), col)] = (_value(e, c, m), m)
    return t


def layout_tyol(
    entries: Sequence[Entry],
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    title: str | None = None,
) -> Table:
    """Rows (method, metric) x one column per category; ranks across methods per column and metric."""
    cats = _categories(entries, categories, ["bottle", "bowl", "can", "plate", "mug"])
    metrics = metrics or DEFAULT_METRICS["tyol"]
    rows = [(e.label, metric(m).md) for e in entries for m in metrics]
    cols = [(c.capitalize(),) for c in cats]
    t = Table(
        title or "Camera pose estimation on TYO-L (symmetric objects by main-axis error)",
        ["Methods", "Metric"],
        rows,
        cols,
        rank_by="column",
    )
    for e in entries:
        for m in metrics:
            for c in cats:
                t.cells[((e.label, metric(m).md), (c.capitalize(),))] = (_value(e, c, m), m)
    return t


LAYOUTS: dict[str, tuple[Callable[..., Table], Callable[[Run], str], str]] = {
    # name: (layout, row group of a run, default error column)
    "generic": (layout_generic, lambda r: "", "err_deg"),
    "optimiser": (layout_optimiser, pipeline_label, "err_deg"),
    "one_template": (layout_one_template, pipeline_label, "err_deg"),
    "templates": (layout_templates, template_count, "oracle_err_deg"),
    "ablation": (layout_ablation, lambda r: f"{r.protocol} {pipeline_label(r)}".replace(" -", ""), "err_deg"),
    "real": (layout_real, lambda r: "", "err_deg"),
    "tyol": (layout_tyol, lambda r: "", "err_deg"),
}


#: layouts renamed: old name -> new name (the old one is refused, naming the new one)
RENAMED_LAYOUTS = {"optimizer": "optimiser"}


def build_table(
    runs: Sequence[Run],
    layout: str = "generic",
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    labels: dict[str, str] | None = None,
    error: str | None = None,
    title: str | None = None,
    stability_roots: Sequence[Path] = (),
    thresholds: Sequence[str] = (),
) -> Table:
    """Lay out ``runs`` as one of :data:`LAYOUTS`.

    ``error`` picks the per-unit error: ``"err_deg"`` (the method's own choice) or
    ``"oracle_err_deg"`` (templates protocol: minimum across templates); the ``templates``
    layout defaults to the oracle, as in the paper, and says so in a note.
    ``stability_roots``: output roots holding the same runs made under other code paths of the
    numerical libraries; the notes then say, per row, how many views changed and the range of
    the overall figures (:mod:`catpose.bench.report.stability`).
    ``thresholds``: metric keys of :mod:`catpose.bench.scoring.curves` (``acc5``, ``auc30``,
    ``5deg5cm``; ``bench table --acc/--auc``) that replace the metrics' accuracies
    (:func:`with_thresholds`).
    """
    if layout in RENAMED_LAYOUTS:
        raise ConfigError(
            f"table layout {layout} was renamed {RENAMED_LAYOUTS[layout]}; write --layout {RENAMED_LAYOUTS[layout]}"
        )
    if layout not in LAYOUTS:
        raise ConfigError(f"unknown table layout {layout!r}; use one of {sorted(LAYOUTS)}")
    from catpose.bench.scoring.bop_rows import AR_KEYS

    chosen = metrics is not None
    if thresholds:
        metrics = with_thresholds(metrics or DEFAULT_METRICS[layout], thresholds)
    if not chosen and any(is_bop_run(r) for r in runs):  # BOP's AR after the layout's metrics
        metrics = list(metrics or DEFAULT_METRICS[layout]) + list(AR_KEYS)
    for m in metrics or []:
        metric(m)  # an unknown key: one line naming the choices
    fn, group_of, default_error = LAYOUTS[layout]
    error = error or default_error
    # Only templates runs have an oracle; other runs in the same table keep their own error.
    oracle = error == "oracle_err_deg"

    def error_of(r: Run) -> str:
        return "oracle_err_deg" if oracle and r.protocol == "templates" else "err_deg"

    entries = collect(runs, group_of, labels, error_of, with_bop=any(m in AR_KEYS for m in metrics or []))
    # Paper order: pipelines from plain to ours, and within one, our method last.
    entries.sort(key=lambda e: (_group_order(e.group), e.group, e.label.startswith("Ours")))
    kwargs = {"title": title} if title else {}
    table = fn(
        entries,
        categories=list(categories) if categories else None,
        metrics=list(metrics) if metrics else None,
        **kwargs,
    )
    prune(table)
    shown = {c[-1] for c in table.columns} | {r[-1] for r in table.rows}
    cm = [m for m in metrics or [] if m not in METRICS and m.endswith("cm") and metric(m).md not in shown]
    if cm:
        table.notes.append(
            f"Left out: {', '.join(cm)} (no run here has rows with a metric scale, info.scale_mm: "
            "their errors are in object-normalised units)."
        )
    if oracle and any(r.protocol == "templates" for r in runs):
        table.notes.append(
            "Errors of templates runs are the minimum across templates (an oracle that needs ground truth)."
        )
    table.notes += [f"Incomplete: {r.incomplete}" for r in runs if getattr(r, "incomplete", None)]
    if stability_roots:
        from catpose.bench.report.stability import stability_notes

        names = [f"{group_of(r)} / {label}".lstrip(" /") for r, label in zip(runs, run_labels(runs, labels, group_of))]
        table.notes += [""] + stability_notes(runs, names, stability_roots, error_of)
    return table


def split_by_protocol(runs: Sequence[Run]) -> dict[str, list[Run]]:
    """Runs per protocol (in first-seen order): errors of different protocols answer different
    questions, so the report gives each its own tables and figures."""
    out: dict[str, list[Run]] = {}
    for r in runs:
        out.setdefault(r.protocol, []).append(r)
    return out


def _group_order(group: str) -> int:
    order = ["-", "", "Direct match FPFH", "Dictionary FPFH", "Dictionary PFH", "Dictionary LPS"]
    if group.isdigit():
        return int(group)
    return order.index(group) if group in order else len(order)
