"""``bench table``: the command line of :mod:`catpose.bench.report.tables`.

bench table RUN_DIR... [--sweep DIR] [--layout L] [--format md|latex|csv] [--out FILE] [--allow-mixed]

Rows scored on different samples (datasets, protocols, seeds, a ``limit`` run) are refused in one
line (exit 2) unless ``--allow-mixed``; the seeds of one configuration are one row (their mean,
with min and max).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from catpose import atomic
from catpose.bench.report.labels import check_labels, parse_labels
from catpose.bench.report.runs import find_run_dirs, load_runs, print_left_out, warn_incomplete
from catpose.bench.report.table_format import METRICS
from catpose.bench.report.tables import LAYOUTS, RENDERERS, build_table
from catpose.errors import ConfigError


def main(argv: list[str] | None = None) -> int:
    """``bench table RUN_DIR... [--sweep DIR] [--layout L] [--format md|latex|csv] [--out FILE]``."""
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
    ap.add_argument(
        "--acc",
        default=None,
        metavar="LIST",
        help="accuracy thresholds replacing @10/@30: degrees and n-degree m-cm, e.g. --acc 5,10,30,5deg5cm "
        "(cm only where rows carry a metric scale: BOP, synthetic with a sensor model)",
    )
    ap.add_argument(
        "--auc",
        type=float,
        default=None,
        metavar="DEG",
        help="add the area under the accuracy-vs-threshold curve from 0 to DEG degrees, over DEG",
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
    ap.add_argument("--out", default=None, help="write here instead of stdout (a new file; see --force)")
    ap.add_argument(
        "--force", action="store_true", help="replace an existing --out (never an input or a verified table)"
    )
    ap.add_argument(
        "--bop-metrics",
        default=None,
        help="BOP recalls of runs scored by `bench score` (bop_errors.jsonl), e.g. "
        "ar_mssd,ar_mspd,adds@0.1,5deg5cm (see catpose.bench.scoring.bop_eval.parse_metric)",
    )
    ap.add_argument("--by", default="object,category", help="with --bop-metrics: rows per object and/or category")
    ap.add_argument(
        "--stability",
        action="append",
        default=[],
        metavar="ROOT",
        help="an output root with the same runs made under another code path of the numerical "
        "libraries (results/make_results.sh); notes say per row how many views changed "
        "and the range of the overall figures (repeatable)",
    )
    args = ap.parse_args(argv)
    from catpose.bench.report.sweep_runs import sweep_runs
    from catpose.bench.scoring.curves import threshold_keys

    run_paths, sweep_labels, defaults = sweep_runs(args.sweep)
    if not args.runs and not run_paths:
        raise ConfigError("no runs: pass run directories or --sweep DIR (a sweep directory of `bench run -m`)")
    if args.out:  # before any work (docs/file-safety.md)
        from catpose.bench.run.overwrite import check_output, input_runs

        check_output(args.out, "file", input_runs([*args.runs, *run_paths, *args.sweep, *args.stability]), args.force)
    if args.bop_metrics:
        from catpose.bench.scoring.bop_eval import table_main_from_runs

        text = (
            table_main_from_runs(
                find_run_dirs([*args.runs, *run_paths]), args.bop_metrics.split(","), args.by.split(",")
            )
            + "\n"
        )
        _write(args.out, text)
        return 0
    if args.layout not in (None, defaults.get("layout")):
        defaults = {}  # another layout than the experiment's: none of its settings apply
    for key, value in defaults.items():  # the experiment's settings, unless given here
        if getattr(args, key) is None and value:
            setattr(args, key, ",".join(map(str, value)) if isinstance(value, list) else str(value))
    args.layout = args.layout or "generic"
    runs, left_out = load_runs([*args.runs, *run_paths])
    check_labels(args.label, runs)
    print_left_out("table", runs, left_out)  # one damaged run does not stop the others; the exit status says so
    warn_incomplete("table", runs)  # and the table's notes say it
    if args.categories:
        check_categories(runs, args.categories.split(","))
    table = build_table(
        runs,
        args.layout,
        args.categories.split(",") if args.categories else None,
        args.metrics.split(",") if args.metrics else None,
        {**sweep_labels, **parse_labels(args.label)},
        args.error,
        args.title,
        [Path(p) for p in args.stability],
        threshold_keys(args.acc or [], args.auc) if (args.acc or args.auc is not None) else (),
        allow_mixed=args.allow_mixed,
    )
    _write(args.out, RENDERERS[args.format](table))
    return 2 if left_out else 0


def _write(out: str | None, text: str) -> None:
    """The table to ``out`` (atomically, one line on a full disk or a read-only folder), or stdout."""
    if not out:
        sys.stdout.write(text)
        return
    from catpose.bench.run.overwrite import output_errors

    with output_errors(out):
        atomic.write_text(out, text)


def check_categories(runs, wanted) -> None:
    """Refuse ``--categories`` that no run has (an empty table otherwise), naming those it has."""
    have = sorted({str(c) for r in runs for c in r.samples.get("category", [])})
    unknown = [c for c in wanted if c not in have and c != "all"]
    if unknown:
        raise ConfigError(
            f"--categories {','.join(unknown)}: no run here has {'that category' if len(unknown) == 1 else 'those'}; "
            f"they have {', '.join(have) or 'none'} (and 'all')"
        )
