"""``make demo``: ICP and ours on the embedded synthetic set, the README's first table, compared.

    python -m catpose.bench.report.demo [--out outputs/demo] [--native]

runs ``bench run method=icp dataset=synthetic`` and ``bench run method=ours dataset=synthetic``
(2 methods x 48 views, each view against its own model; resumed when run before) into
``<out>/<profile>/``, prints their tables as the report writes them, per category (the paper's
layout, ``results/report/tables/gt_model_per_category.md``) and pooled (the README quotes
``results/report/tables/gt_model_summary.md``), and says how the pooled rows compare with the
quoted ones.

The numeric profile: the README's tables are made under the portable profile
(:func:`catpose.bench.run.environment.portable_profile`: OpenBLAS's Haswell kernel, NumPy without
its AVX-512 loops, torch's AVX2 kernels, numba for Haswell), so the demo runs under it too and
prints the same figures on any x86-64 CPU with AVX2, AVX-512 ones included. ``--native`` runs on
the machine's own code paths instead: on an AVX-512 CPU, ICP's mean then moves (two mug and bowl
views flip; ``results/tables/gt_model_all.md`` gives each figure's range across the code paths).
The time column is this machine's, never the README's.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from catpose.errors import ConfigError

#: the README's quoted table: the report's summary of the embedded set (results/make_results.sh)
QUOTED = Path("results/report/tables/gt_model_summary.csv")
#: method -> the label of its row in the quoted table
ROWS = {"icp": "ICP", "ours": "Ours"}
#: columns compared with the quote (time is the machine's)
TIME_COLUMN = "time [s] ↓"


def profile_env(native: bool) -> tuple[str, dict[str, str]]:
    """``(description, environment)`` the demo's runs start with."""
    from catpose.bench.run.environment import portable_profile

    if native:
        return "native (this CPU's own code paths; the README's figures may differ on AVX-512 CPUs)", dict(os.environ)
    profile = portable_profile()
    if not profile:
        return "native (no AVX2 on this CPU, so no portable profile)", dict(os.environ)
    shown = " ".join(f"{k}={v}" for k, v in profile.items())
    return f"portable ({shown}), the one the README's tables are made under", dict(os.environ) | profile


def run_methods(out: Path, env: dict[str, str]) -> list[Path]:
    """``bench run method=M dataset=synthetic output_root=OUT`` for ICP and ours; their run directories."""
    from catpose.bench.run.config import compose
    from catpose.bench.run.rundir import run_dir_for

    dirs = []
    for method in ROWS:
        overrides = [f"method={method}", "dataset=synthetic", f"output_root={out}"]
        print(f"make demo: bench run {' '.join(overrides)}", flush=True)
        code = subprocess.run(
            [sys.executable, "-m", "catpose.bench.cli", "run", *overrides, "print_summary=false"], env=env
        ).returncode
        if code != 0:
            raise ConfigError(f"bench run {' '.join(overrides)} failed (exit {code}); see its message above")
        dirs.append(run_dir_for(compose(overrides), overrides))
    return dirs


def demo_tables(run_dirs: list[Path]):
    """``(per category, pooled)``: the runs' tables as the report writes them
    (:func:`~catpose.bench.report.report_folder.per_category_table`, ``summary_table``)."""
    from catpose.bench.report.report_folder import per_category_table, summary_table
    from catpose.bench.report.runs import load_runs

    runs, reasons = load_runs(run_dirs)
    if reasons:
        raise ConfigError("; ".join(reasons))
    labels = {str(r.path): ROWS[str(r.method)] for r in runs}
    return per_category_table(runs, labels, "gt_model"), summary_table(runs, labels, "gt_model")


def differences(table_csv: str, quoted_csv: str, rel: float = 1e-9) -> list[str]:
    """Cells of the demo's table (CSV text) that differ from the quoted table's rows of the same
    label, time aside: ``["ICP Mean° ↓: 10.524 here, 14.249 quoted", ...]``; empty when all agree."""
    import io
    import math

    import pandas as pd

    here = pd.read_csv(io.StringIO(table_csv), index_col=0)
    quoted = pd.read_csv(io.StringIO(quoted_csv), index_col=0)
    out = []
    for label in here.index:
        if label not in quoted.index:
            out.append(f"{label}: no row in the quoted table")
            continue
        for col in here.columns:
            if col == TIME_COLUMN:
                continue
            a, b = float(here.loc[label, col]), float(quoted.loc[label, col])
            if not math.isclose(a, b, rel_tol=rel, abs_tol=1e-12):
                out.append(f"{label} {col}: {a:.3f} here, {b:.3f} quoted")
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m catpose.bench.report.demo [--out DIR] [--native]`` (``make demo``)."""
    from catpose.bench.report.tables import RENDERERS

    ap = argparse.ArgumentParser(prog="make demo", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="outputs/demo", help="output root; the runs go to OUT/<profile>/")
    ap.add_argument("--native", action="store_true", help="this CPU's own code paths instead of the portable profile")
    ap.add_argument("--quoted", default=str(QUOTED), help="the quoted table's CSV to compare with")
    args = ap.parse_args(argv)
    described, env = profile_env(args.native)
    print(f"make demo: numeric profile: {described}", flush=True)
    out = Path(args.out) / ("native" if args.native else "portable")
    per_category, table = demo_tables(run_methods(out, env))
    if per_category is not None:
        print("\n" + RENDERERS["md"](per_category))
    print("\n" + RENDERERS["md"](table))
    quoted = Path(args.quoted)
    if not quoted.is_file():
        print(f"make demo: no {quoted} here (not a checkout): nothing to compare with")
        return 0
    diff = differences(RENDERERS["csv"](table), quoted.read_text())
    if diff:
        print(f"make demo: differs from the README's table ({quoted.with_suffix('.md')}): " + "; ".join(diff))
        return 1
    print(
        f"make demo: ICP and Ours agree with the README's table ({quoted.with_suffix('.md')}) in every "
        "error column; the time column is this machine's"
    )
    return 0


if __name__ == "__main__":
    from catpose.errors import CatposeError, command_error

    try:
        raise SystemExit(main())
    except CatposeError as e:
        print(command_error("demo", e).replace("bench demo", "make demo"), file=sys.stderr)
        raise SystemExit(2) from None
