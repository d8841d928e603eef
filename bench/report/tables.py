"""Paper tables from run directories (files only): the layouts and the notes under a table.

A run's per-sample rows become scoring units by the run's own protocol; the runs sharing one row
label are pooled into an :class:`Entry` (per category, and per seed when it pools seeds) whose
cells are a summary statistic, a threshold statistic or BOP's AR, and laid out as one of :data:`LAYOUTS` (one
:class:`Layout` spec each: ``optimiser``, ``one_template``, ``templates``, ``ablation``, ``real``,
``tyol`` are the paper's tables, ``generic`` any runs x categories x metrics). Best values are
bold and second best underlined (errors lower, accuracies higher); BOP-layout runs also get
BOP'19's AR and its parts. Rows scored on different samples are refused
(:mod:`catpose.bench.report.tables_compare`); a configuration's seeds pool into one row, the
mean with the min and max. Output: Markdown, LaTeX or CSV.

    bench table outputs/modelnet40-gt_model --layout optimiser --format latex"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from catpose.bench.report.labels import pipeline_label, run_labels, template_count
from catpose.bench.report.runs import Run, scored_units
from catpose.bench.report.table_format import METRICS, Table, metric, prune, to_csv, to_latex, to_markdown
from catpose.bench.report.tables_compare import FIX, mixed_rows, seed_of
from catpose.bench.run.bop_ar import AR_KEYS, is_bop_layout, target_errors
from catpose.bench.scoring.bop_eval import metric_value
from catpose.bench.scoring.curves import statistic
from catpose.bench.scoring.metrics import summarize
from catpose.errors import ConfigError, DatasetError

RENDERERS: dict[str, Callable[[Table], str]] = {"md": to_markdown, "latex": to_latex, "csv": to_csv}


# --------------------------------------------------------------------------------------------
# Rows


@dataclass
class Entry:
    """The runs sharing one row label, pooled: per-category statistics, and the same per seed.

    With one seed the cells are ``summary``'s; with several, each cell is the mean of the seeds'
    values (``per_seed``) and the table shows their min and max beside it."""

    group: str
    label: str
    summary: Any  # DataFrame from metrics.summarize, indexed by category
    units: Any = None  # the pooled scoring units (DataFrame): statistics beyond the summary's (curves)
    bop: Any = None  # the pooled per-target BOP errors (DataFrame) of runs on BOP-layout data, or None
    runs: list = field(default_factory=list)  # the runs pooled here
    per_seed: list = field(default_factory=list)  # one Entry per seed (when more than one)
    seeds: list = field(default_factory=list)


def pool_entry(group: str, label: str, units: list, bop: list, runs: list | None = None) -> Entry:
    import pandas as pd

    pooled = pd.concat(units, ignore_index=True)
    errors = pd.concat(bop, ignore_index=True) if bop else None
    return Entry(group, label, summarize(pooled).set_index("category"), pooled, errors, list(runs or []))


def collect(
    runs: Sequence[Run],
    group_of: Callable[[Run], str],
    labels: dict[str, str] | None = None,
    error_of: Callable[[Run], str] = lambda r: "err_deg",
    with_bop: bool = False,
) -> list[Entry]:
    """Pool the scoring units of runs with the same (group, label) and summarize per category;
    the seeds of one configuration share a label (:func:`run_labels`), and each seed is also
    summarized alone (``Entry.per_seed``) for the mean and spread across seeds.

    ``labels`` maps a run directory (as given, or its name) to a user label; labels are made
    unique within a group by :func:`run_labels`. ``error_of`` names the error column each run is
    scored by (see :func:`scored_units`). ``with_bop``: also pool the runs' per-target BOP errors
    (runs on BOP-layout data; :func:`catpose.bench.run.bop_ar.target_errors`).
    """
    parts: dict[tuple[str, str], dict[Any, tuple[list, list, list]]] = {}
    for run, label in zip(runs, run_labels(runs, labels, group_of)):
        units, bop, members = parts.setdefault((group_of(run), label), {}).setdefault(seed_of(run), ([], [], []))
        units.append(scored_units(run, error_of(run)))
        members.append(run)
        errors = target_errors(run.path) if with_bop else None
        if errors is not None and len(errors):
            bop.append(errors)
    entries = []
    for (group, label), by_seed in parts.items():
        entry = pool_entry(
            group,
            label,
            [u for s in by_seed.values() for u in s[0]],
            [b for s in by_seed.values() for b in s[1]],
            [r for s in by_seed.values() for r in s[2]],
        )
        if len(by_seed) > 1:
            entry.seeds = sorted(by_seed, key=str)
            entry.per_seed = [pool_entry(group, label, *by_seed[s]) for s in entry.seeds]
        entries.append(entry)
    return entries


def is_bop_run(run: Run) -> bool:
    """Whether a run is on BOP-layout data (its table rows can show BOP's AR)."""
    return is_bop_layout(run.config.get("dataset"))


def cell(entry: Entry, category: str, key: str) -> tuple[float, tuple[float, float] | None]:
    """A statistic of the entry's units of ``category`` (``all``: every unit) (:func:`one_value`),
    and None; when it pools several seeds, the mean of their values and their (min, max)."""
    if not entry.per_seed:
        return one_value(entry, category, key), None
    values = [one_value(e, category, key) for e in entry.per_seed]
    return (float(np.mean(values)) if all(np.isfinite(values)) else float("nan")), (min(values), max(values))


def one_value(entry: Entry, category: str, key: str) -> float:
    """A summary statistic, or a threshold statistic (``acc5``, ``auc30``, ``5deg5cm``:
    :mod:`catpose.bench.scoring.curves`) of the entry's units of ``category`` (``all``: every unit)."""
    if key in AR_KEYS:
        if entry.bop is None:
            return float("nan")
        errors = entry.bop if category == "all" else entry.bop[entry.bop["category"].astype(str) == category]
        return metric_value(errors, key) if len(errors) else float("nan")
    if key not in METRICS:
        if category not in entry.summary.index or entry.units is None:
            return float("nan")
        units = entry.units if category == "all" else entry.units[entry.units["category"].astype(str) == category]
        return statistic(units, key)
    col = METRICS[key].column
    if category not in entry.summary.index or col not in entry.summary.columns:
        return float("nan")
    return float(entry.summary.loc[category, col])


def pick_categories(
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


def n_note(entries: Sequence[Entry]) -> str:
    """Every row's scored units (per seed when it pools seeds) and seeds."""
    parts = []
    for e in entries:
        name = f"{e.group} / {e.label}".lstrip(" /")
        if e.per_seed:
            ns = sorted({len(p.units) for p in e.per_seed})
            n = "/".join(map(str, ns))
            parts.append(f"{name} {n} x {len(e.seeds)} seeds ({', '.join(map(str, e.seeds))})")
        else:
            seeds = sorted({str(seed_of(r)) for r in e.runs})
            parts.append(f"{name} {len(e.units)} (seed {', '.join(seeds)})")
    return "n (scored units): " + "; ".join(parts) + "."


# --------------------------------------------------------------------------------------------
# Layouts


@dataclass(frozen=True)
class Layout:
    """One table layout: its shape, defaults and how runs group into rows.

    ``shape``: ``grid`` (rows (group, method) x columns (category, metric); ranks per column),
    ``real`` (rows (category, metric) x one column per method; ranks across methods within a row)
    or ``tyol`` (rows (method, metric) x one column per category; ranks per column and metric).
    ``group_of`` None: no group column. ``with_all``: an ``all`` category after the others when
    none are given."""

    shape: str
    metrics: tuple[str, ...]
    title: str
    categories: tuple[str, ...] = ()
    group_of: Callable[[Run], str] | None = None
    group_header: str = "Pipeline / Descriptor"
    error: str = "err_deg"
    with_all: bool = False


LAYOUTS: dict[str, Layout] = {
    "generic": Layout("grid", ("mean", "median", "acc10", "acc30", "trans"), "Results", with_all=True),
    "optimiser": Layout(
        "grid",
        ("mean", "median", "trans"),
        "Partial point cloud registration with the ground-truth complete shape",
        ("airplane", "chair", "car"),
        pipeline_label,
    ),
    "one_template": Layout(
        "grid",
        ("mean", "median", "acc10", "acc30", "trans"),
        "Registration with one category-level template (airplane)",
        ("airplane",),
        pipeline_label,
    ),
    "templates": Layout(
        "grid",
        ("mean", "median", "acc10", "acc30"),
        "Registration with several category-level templates (chair)",
        ("chair",),
        template_count,
        "Number of templates",
        error="oracle_err_deg",
    ),
    "ablation": Layout(
        "grid",
        ("mean", "median", "acc10"),
        "Registration with and without the pose optimisation (airplane)",
        ("airplane",),
        lambda r: f"{r.protocol} {pipeline_label(r)}".replace(" -", ""),
        "Setting",
    ),
    "real": Layout(
        "real",
        ("mean", "median", "acc10", "acc30"),
        "Pairwise relative pose between two partial views of real scans",
        ("airplane", "chair", "car"),
    ),
    "tyol": Layout(
        "tyol",
        ("mean", "median", "acc10", "acc30"),
        "Camera pose estimation on TYO-L (symmetric objects by main-axis error)",
        ("bottle", "bowl", "can", "plate", "mug"),
    ),
}


def lay_out(spec: Layout, entries: Sequence[Entry], cats: Sequence[str], metrics: Sequence[str], title: str) -> Table:
    """The table of ``entries`` in the layout ``spec`` (categories ``cats``, ``metrics``)."""
    md = {m: metric(m).md for m in metrics}
    grouped = spec.group_of is not None
    # per shape: the leading headers, the (entry, category, metric) in the order that lists the rows and columns,
    # and where each statistic goes, (row, column)
    if spec.shape == "grid":
        lead = [spec.group_header, "Methods"] if grouped else ["Methods"]
        order = [(e, c, m) for e in entries for c in cats for m in metrics]
        where = lambda e, c, m: ((e.group, e.label) if grouped else (e.label,), (c.capitalize(), md[m]))  # noqa: E731
    elif spec.shape == "real":
        lead, order = ["Category", "Metric"], [(e, c, m) for c in cats for m in metrics for e in entries]
        where = lambda e, c, m: ((c.capitalize(), md[m]), (e.label,))  # noqa: E731
    else:
        lead, order = ["Methods", "Metric"], [(e, c, m) for e in entries for m in metrics for c in cats]
        where = lambda e, c, m: ((e.label, md[m]), (c.capitalize(),))  # noqa: E731
    places = [where(*k) for k in order]
    rows, columns = list(dict.fromkeys(r for r, _ in places)), list(dict.fromkeys(c for _, c in places))
    t = Table(title, lead, rows, columns, rank_by="row" if spec.shape == "real" else "column")
    for (e, c, m), place in zip(order, places):
        value, spread = cell(e, c, m)
        t.cells[place] = (value, m)
        if spread is not None:
            t.spread[place] = spread
    return t


def build_table(
    runs: Sequence[Run],
    layout: str = "generic",
    categories: Sequence[str] | None = None,
    metrics: Sequence[str] | None = None,
    labels: dict[str, str] | None = None,
    error: str | None = None,
    title: str | None = None,
    allow_mixed: bool = False,
) -> Table:
    """Lay out ``runs`` as one of :data:`LAYOUTS`.

    ``error`` picks the per-unit error: ``"err_deg"`` (the method's own choice) or
    ``"oracle_err_deg"`` (templates protocol: minimum across templates); the ``templates``
    layout defaults to the oracle, as in the paper, and says so in a note. ``metrics``: keys of
    :data:`~catpose.bench.report.table_format.METRICS` or of :mod:`catpose.bench.scoring.curves`
    (``acc5``, ``auc30``, ``5deg5cm``), default the layout's.

    Rows that were not scored on the same samples (another dataset, protocol, seeds, a ``limit``
    run: :func:`catpose.bench.report.tables_compare.mixed_rows`) are a one-line
    :class:`~catpose.errors.DatasetError` naming the runs and what differs; ``allow_mixed`` builds
    the table anyway and says so in a note. The seeds of one configuration are one row: the mean
    across seeds, their min and max beside it; a note gives every row's n and seeds.
    """
    if layout not in LAYOUTS:
        raise ConfigError(f"unknown table layout {layout!r}; use one of {sorted(LAYOUTS)}")

    spec = LAYOUTS[layout]
    if metrics is None and any(is_bop_run(r) for r in runs):  # BOP's AR after the layout's metrics
        metrics = list(metrics or spec.metrics) + list(AR_KEYS)
    metrics = list(metrics or spec.metrics)
    for m in metrics:
        metric(m)  # an unknown key: one line naming the choices
    group_of = spec.group_of or (lambda r: "")
    error = error or spec.error
    # Only templates runs have an oracle; other runs in the same table keep their own error.
    oracle = error == "oracle_err_deg"

    def error_of(r: Run) -> str:
        return "oracle_err_deg" if oracle and r.protocol == "templates" else "err_deg"

    entries = collect(runs, group_of, labels, error_of, with_bop=any(m in AR_KEYS for m in metrics))
    # Paper order: pipelines from plain to ours, and within one, our method last.
    entries.sort(key=lambda e: (_group_order(e.group), e.group, e.label.startswith("Ours")))
    cats = pick_categories(entries, categories, spec.categories) + (["all"] if spec.with_all and not categories else [])
    mixed = mixed_rows([(f"{e.group} / {e.label}".lstrip(" /"), e.runs) for e in entries], cats)
    if mixed and not allow_mixed:
        raise DatasetError(f"{mixed}; {FIX}")
    table = lay_out(spec, entries, cats, metrics, title or spec.title)
    prune(table)
    if mixed:
        table.notes.append(f"Mixed (--allow-mixed): {mixed}; its rows do not compare.")
    table.notes.append(n_note(entries))
    if any(e.per_seed for e in entries):
        table.notes.append("Cells pooling several seeds: the mean across seeds [their min, max].")
    shown = {c[-1] for c in table.columns} | {r[-1] for r in table.rows}
    cm = [m for m in metrics if m not in METRICS and m.endswith("cm") and metric(m).md not in shown]
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
