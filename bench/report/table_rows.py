"""The rows of a paper table, from run directories: the runs sharing one row label pooled into an
:class:`Entry` (per category, and per seed when it pools seeds), and the value of one cell of it
(a summary statistic, a threshold statistic or BOP's AR). :mod:`catpose.bench.report.tables` lays
the entries out."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from catpose.bench.report.labels import run_labels
from catpose.bench.report.runs import Run, scored_units
from catpose.bench.report.table_format import METRICS


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

    from catpose.bench.scoring.metrics import summarize

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
    from catpose.bench.report.tables_compare import seed_of
    from catpose.bench.run.bop_ar import target_errors

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
    from catpose.bench.run.bop_ar import is_bop_layout

    return is_bop_layout(run.config.get("dataset"))


def cell(entry: Entry, category: str, key: str) -> tuple[float, tuple[float, float] | None]:
    """A statistic of the entry's units of ``category`` (``all``: every unit) (:func:`one_value`),
    and None; when it pools several seeds, the mean of their values and their (min, max)."""
    if not entry.per_seed:
        return one_value(entry, category, key), None
    import numpy as np

    values = [one_value(e, category, key) for e in entry.per_seed]
    return (float(np.mean(values)) if all(np.isfinite(values)) else float("nan")), (min(values), max(values))


def one_value(entry: Entry, category: str, key: str) -> float:
    """A summary statistic, or a threshold statistic (``acc5``, ``auc30``, ``5deg5cm``:
    :mod:`catpose.bench.scoring.curves`) of the entry's units of ``category`` (``all``: every unit)."""
    from catpose.bench.run.bop_ar import AR_KEYS

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
    from catpose.bench.report.tables_compare import seed_of

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
