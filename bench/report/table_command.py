"""``bench table``: the command line of :mod:`catpose.bench.report.tables`.

bench table RUN_DIR... [--sweep DIR] [--layout L] [--format md|latex|csv] [--out FILE] [--allow-mixed]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from catpose import atomic
from catpose.bench.report.labels import parse_labels
from catpose.bench.report.runs import find_run_dirs, load_runs, print_left_out
from catpose.bench.report.table_format import METRICS
from catpose.bench.report.tables import LAYOUTS, RENDERERS, build_table
from catpose.errors import ConfigError, DatasetError


def parser() -> argparse.ArgumentParser:
    """``bench table``'s options."""
    from catpose.bench.run.overwrite import add_output_options

    ap = argparse.ArgumentParser(prog="bench table", description="Paper tables from run directories.")
    ap.add_argument("runs", nargs="*", help="run directories, or folders searched for samples.jsonl")
    ap.add_argument(
        "--sweep",
        action="append",
        default=[],
        metavar="DIR",
        help="a sweep directory of `bench run -m` (<output_root>/multirun/<name>/<time>): its jobs' "
        "runs and labels, and the experiment's table settings (repeatable)",
    )
    ap.add_argument(
        "--layout",
        default=None,
        choices=sorted(LAYOUTS),
        help="default: the sweep's, else generic",
    )
    ap.add_argument("--format", default="md", choices=sorted(RENDERERS))
    ap.add_argument("--categories", default=None, help="comma-separated categories (default: the layout's)")
    ap.add_argument(
        "--metrics",
        default=None,
        help=f"comma-separated, of {','.join(METRICS)} or acc<X>, auc<X>, <n>deg<m>cm (catpose.bench.scoring.curves)",
    )
    ap.add_argument("--label", action="append", default=[], help="RUN_DIR=LABEL, repeatable")
    ap.add_argument(
        "--error",
        default=None,
        choices=["err_deg", "oracle_err_deg"],
        help="the method's own choice or the minimum across templates (oracle)",
    )
    ap.add_argument("--title", default=None)
    ap.add_argument(
        "--allow-mixed",
        action="store_true",
        help="put rows of different datasets, protocols, seeds or sample sets (a limit= run) in one table "
        "anyway (refused otherwise); the table says so in a note",
    )
    add_output_options(ap, "write here instead of stdout (a new file; see --force)", required=False)
    ap.add_argument(
        "--bop-metrics",
        default=None,
        help="BOP recalls of runs scored by `bench score` (bop_errors.jsonl), e.g. "
        "ar_mssd,ar_mspd,adds@0.1,5deg5cm (see catpose.bench.scoring.bop_eval.parse_metric)",
    )
    ap.add_argument("--by", default=None, help="with --bop-metrics: rows per object and/or category (default both)")
    return ap


def main(argv: list[str] | None = None) -> int:
    """``bench table RUN_DIR... [--sweep DIR] [--layout L] [--format md|latex|csv] [--out FILE]``."""
    args = parser().parse_args(argv)
    swept = sweep_runs(args.sweep)
    out = output(args, swept[0])
    if args.by is not None and (not args.bop_metrics or set(args.by.split(",")) - {"object", "category"}):
        raise ConfigError(f"--by {args.by!r} goes with --bop-metrics and takes object, category or object,category")
    if args.bop_metrics:
        run_dirs = find_run_dirs([*args.runs, *swept[0]])
        by = (args.by or "object,category").split(",")
        _write(out, bop_recall_table(run_dirs, args.bop_metrics.split(","), by) + "\n")
        return 0
    table, left_out = make_table(args, swept)[:2]
    _write(out, RENDERERS[args.format](table))
    return 2 if left_out else 0


def output(args, run_paths: Sequence[Path], extra_inputs: Sequence[str | Path] = ()):
    """The ``--out`` of ``args`` (an :class:`~catpose.bench.run.overwrite.Output`, checked before any
    work: docs/file-safety.md), or None for stdout; no runs at all is refused first."""
    if not args.runs and not run_paths:
        raise ConfigError("no runs: pass run directories or --sweep DIR (a sweep directory of `bench run -m`)")
    if not args.out:
        return None
    from catpose.bench.run.overwrite import Output, input_runs

    return Output(args.out, "file", input_runs([*args.runs, *run_paths, *args.sweep, *extra_inputs]), args.force)


def make_table(args, swept):
    """``(table, left_out, runs, labels)`` of ``bench table``'s ``args`` (not ``--bop-metrics``) and
    its sweeps' ``(run directories, labels, table settings)``."""
    run_paths, sweep_labels, defaults = swept
    if args.layout not in (None, defaults.get("layout")):
        defaults = {}  # another layout than the experiment's: none of its settings apply
    for key, value in defaults.items():  # the experiment's settings, unless given here
        if getattr(args, key) is None and value:
            setattr(args, key, ",".join(map(str, value)) if isinstance(value, list) else str(value))
    args.layout = args.layout or "generic"
    runs, left_out = load_runs([*args.runs, *run_paths])
    labels = {**sweep_labels, **parse_labels(args.label, runs)}
    print_left_out("table", runs, left_out)  # one damaged run does not stop the others; the exit status says so
    if args.categories:
        check_categories(runs, args.categories.split(","))
    table = build_table(
        runs,
        args.layout,
        args.categories.split(",") if args.categories else None,
        args.metrics.split(",") if args.metrics else None,
        labels,
        args.error,
        args.title,
        allow_mixed=args.allow_mixed,
    )
    return table, left_out, runs, labels


def _write(out, text: str) -> None:
    """The table to ``out`` (an :class:`~catpose.bench.run.overwrite.Output`), or stdout without one."""
    if out is None:
        sys.stdout.write(text)
        return
    with out.writing() as path:
        atomic.write_text(path, text)


def check_categories(runs, wanted) -> None:
    """Refuse ``--categories`` that no run has (an empty table otherwise), naming those it has."""
    have = sorted({str(c) for r in runs for c in r.samples.get("category", [])})
    unknown = [c for c in wanted if c not in have and c != "all"]
    if unknown:
        raise ConfigError(
            f"--categories {','.join(unknown)}: no run here has {'that category' if len(unknown) == 1 else 'those'}; "
            f"they have {', '.join(have) or 'none'} (and 'all')"
        )


def bop_recall_table(run_dirs: Sequence[str | Path], metrics: Sequence[str], by: Sequence[str]) -> str:
    """One Markdown table of per-object/per-category recalls, a ``method`` column first, for
    every run directory with a ``bop_errors.jsonl`` (``bench table --bop-metrics``), preceded
    by each run's evaluation filters."""
    import pandas as pd

    from catpose.bench.scoring.bop_eval import ERRORS_FILE, read_errors, score_table

    tables, notes = [], []
    for d in run_dirs:
        path = Path(d) / ERRORS_FILE
        if not path.is_file():
            continue
        df, header = read_errors(path)
        method = str(header.get("method", Path(d).name))
        t = score_table(df, metrics, by)
        t.insert(0, "method", method)
        tables.append(t)
        notes.append(
            f"- {method}: "
            + "; ".join(
                [
                    *header.get("filters", []),
                    f"{header.get('matched', 0)}/{header.get('targets', len(df))} targets with an estimate",
                ]
            )
        )
    if not tables:
        raise DatasetError(f"none of {', '.join(map(str, run_dirs))} has a {ERRORS_FILE}; write one with `bench score`")
    table = pd.concat(tables, ignore_index=True).sort_values(
        ["group", "name", "method"],
        kind="stable",
        key=lambda c: c.map({"object": 0, "category": 1, "all": 2}) if c.name == "group" else c,
    )
    return "\n".join(notes) + "\n\n" + table.to_markdown(index=False, floatfmt=".3f")


def sweep_runs(sweep_dirs: Sequence[str | Path]) -> tuple[list[Path], dict[str, str], dict[str, Any]]:
    """Run directories, labels and table settings of sweeps (``bench run -m``).

    Reads each job's ``job.json`` (:mod:`catpose.bench.run.sweep`) and the sweep's ``multirun.yaml``,
    whose ``table`` node (set by ``configs/experiment/*.yaml``) gives ``layout``, ``categories``,
    ``metrics``, ``error`` and ``title``. A failed or unfinished job stops the table with a
    one-line error naming it."""
    from catpose.bench.run.sweep import read_sweep

    paths: list[Path] = []
    labels: dict[str, str] = {}
    settings: dict[str, Any] = {}
    for d in map(Path, sweep_dirs):
        records = read_sweep(d)
        if not records:
            raise DatasetError(
                f"{d} is not a sweep directory (no */job.json); pass <output_root>/multirun/<name>/<time> "
                f"of a `bench run -m` that has finished"
            )
        bad = [r for r in records if r.get("status") != "ok" or not r.get("run_dir")]
        if bad:
            raise DatasetError(
                f"sweep {d}: job {bad[0].get('job')} ({' '.join(bad[0].get('overrides') or [])}) failed: "
                f"{bad[0].get('error')}; re-run the sweep (finished samples are skipped)"
            )
        for r in records:
            run_dir = Path(r["run_dir"])
            if run_dir not in paths:
                paths.append(run_dir)
            if r.get("label"):
                labels.update({str(run_dir): r["label"], str(run_dir.resolve()): r["label"]})
        if (d / "multirun.yaml").is_file() and not settings:
            from omegaconf import OmegaConf

            table = OmegaConf.to_container(OmegaConf.load(d / "multirun.yaml"), resolve=False).get("table") or {}
            settings = {k: v for k, v in table.items() if k in ("layout", "categories", "metrics", "error", "title")}
    from catpose.bench.report.tables import LAYOUTS

    if settings.get("layout") not in (None, *LAYOUTS):
        raise ConfigError(f"the sweep's table.layout {settings['layout']!r} is not one of {sorted(LAYOUTS)}")
    return paths, labels, settings
