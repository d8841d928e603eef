"""How far a table's numbers move under another CPU's arithmetic: ``bench table`` with notes that
compare its runs with the same runs made under other code paths of the numerical libraries.

    python experiments/stability/stability.py BENCH_TABLE_ARGS... --stability ROOT [--stability ROOT ...]

An ambiguous view (a mug with its handle hidden, a symmetric can, a solver's tie-break) can be
decided by the last bit of a sum, and the last bits depend on the CPU's BLAS kernel, NumPy's
dispatched loops and torch's kernels (:func:`catpose.bench.run.environment.numeric_variants`).
``results/make_results.sh`` runs every experiment once more under each of several such code
paths, each into its own output root; :func:`stability_notes` lines each table's runs up with
their twins there (a run directory is ``<output_root>/<dataset>-<protocol>/<method>/<name>``, so a
twin is the same last three path parts under another root) and says, per run, how many scored
units (views, view pairs) changed their error by more than :data:`CHANGED_DEG` and the range of
the overall mean and accuracies. A difference between two methods smaller than those ranges is
not evidence that one is better. The table is ``bench table``'s (the same options), the notes
under it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from catpose.errors import DatasetError

#: an answer "changed" when its error moved by more than this (degrees): the regression gate's
#: chaos threshold (configs/regress/default.yaml)
CHANGED_DEG = 1.0


@dataclass(frozen=True)
class Stability:
    """One run's numbers under its code-path variants (the first value is the run's own).

    Attributes:
        n: scored units of the run.
        changed: units whose error moved by more than :data:`CHANGED_DEG` under any variant.
        mean_deg, acc10, acc30: the overall statistic of the run and of each variant.
    """

    n: int
    changed: int
    mean_deg: tuple[float, ...]
    acc10: tuple[float, ...]
    acc30: tuple[float, ...]


def _unit_errors(run, error: str):
    """{unit key: error in degrees (failures 180)} of a run's scored units."""
    import pandas as pd

    from catpose.bench.report.runs import scored_units

    units = scored_units(run, error)
    if len(units) == 0:
        return pd.Series(dtype=float)
    key = "group_id" if run.protocol == "templates" else "sample_id"
    err = pd.to_numeric(units["err_deg"], errors="coerce").where(units["status"] == "ok", 180.0).fillna(180.0)
    return pd.Series(err.to_numpy(), index=units[key].astype(str).to_numpy())


def twin(run_dir: Path, variant_root: Path) -> Path:
    """The run directory of the same configuration under another output root."""
    return Path(variant_root).joinpath(*Path(run_dir).parts[-3:])


def _pooled_errors(runs: Sequence, root: Path | None, error_of: Callable):
    """Unit errors of ``runs`` pooled into one series (keys prefixed by the run's directory name),
    read from the runs themselves (``root`` None) or from their twins under ``root``."""
    import pandas as pd

    from catpose.bench.report.runs import load_run

    parts = []
    for run in runs:
        if root is not None:
            path = twin(run.path, root)
            if not (path / "samples.jsonl").is_file():
                raise DatasetError(
                    f"{path} is missing: the variant root {root} has no twin of {run.path}; "
                    "re-run results/make_results.sh to complete it"
                )
            run = load_run(path)
        e = _unit_errors(run, error_of(run))
        parts.append(pd.Series(e.to_numpy(), index=[f"{Path(run.path).parts[-2]}/{k}" for k in e.index]))
    return pd.concat(parts) if parts else pd.Series(dtype=float)


def stability(runs: Sequence, variant_roots: Sequence[Path], error_of: Callable = lambda run: "err_deg") -> Stability:
    """Compare the pooled units of ``runs`` (:class:`~catpose.bench.report.runs.Run`, one table row) with
    their twins under each of ``variant_roots``.

    Raises :class:`DatasetError` naming what is missing when a variant root lacks a twin or some
    of its units (re-run ``results/make_results.sh`` to complete it). ``error_of(run)`` names the
    error column each run is scored by, as in the table.
    """
    import numpy as np

    base = _pooled_errors(runs, None, error_of)
    series = [base]
    for root in variant_roots:
        other = _pooled_errors(runs, Path(root), error_of)
        missing = sorted(set(base.index) - set(other.index))
        if missing:
            raise DatasetError(
                f"the variant root {root} lacks {len(missing)} of {len(base)} units "
                f"(e.g. {missing[0]}); re-run results/make_results.sh to complete it"
            )
        series.append(other.reindex(base.index))
    moves = np.max([np.abs(x.to_numpy() - base.to_numpy()) for x in series], axis=0) if len(base) else np.zeros(0)
    return Stability(
        n=len(base),
        changed=int((moves > CHANGED_DEG).sum()),
        mean_deg=tuple(float(x.mean()) for x in series),
        acc10=tuple(float((x <= 10.0).mean()) for x in series),
        acc30=tuple(float((x <= 30.0).mean()) for x in series),
    )


def _range(values: tuple[float, ...], fmt: str) -> str:
    lo, hi = min(values), max(values)
    return format(values[0], fmt) if lo == hi else f"{format(values[0], fmt)} ({format(lo, fmt)}-{format(hi, fmt)})"


def stability_notes(
    runs: Sequence, labels: Sequence[str], variant_roots: Sequence[Path], error_of: Callable = lambda run: "err_deg"
) -> list[str]:
    """Lines for a table's notes: per row label (runs sharing a label pooled), units changed under the variants and the ranges of the
    overall mean error, @10 and @30 (the run's own value first, the range over all code paths in
    parentheses when it is not a single value)."""
    roots = [Path(r) for r in variant_roots]
    lines = [
        f"Stability under {len(roots)} other code path(s) of the numerical libraries "
        f"({', '.join(r.name for r in roots)}): views whose error moved by more than {CHANGED_DEG:g} deg, "
        "and each overall figure as 'own value (min-max over all code paths)'. A difference between "
        "methods smaller than these ranges is chaos of ambiguous views, not evidence."
    ]
    groups: dict[str, list] = {}
    for run, label in zip(runs, labels):
        groups.setdefault(label, []).append(run)
    for label, members in groups.items():
        s = stability(members, roots, error_of)
        lines.append(
            f"- {label}: {s.changed} of {s.n} changed; mean {_range(s.mean_deg, '.2f')} deg, "
            f"@10 {_range(s.acc10, '.3f')}, @30 {_range(s.acc30, '.3f')}"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    """``bench table``'s options and ``--stability ROOT`` (repeatable): the table with the notes."""
    from catpose import atomic
    from catpose.bench.report import table_command, tables
    from catpose.bench.report.labels import run_labels

    ap = table_command.parser()
    ap.add_argument("--stability", action="append", default=[], metavar="ROOT", help="an output root of twins")
    args = ap.parse_args(argv)
    swept = table_command.sweep_runs(args.sweep)
    out = table_command.output(args, swept[0], args.stability)
    table, left_out, runs, labels = table_command.make_table(args, swept)
    if args.stability:
        spec = tables.LAYOUTS[args.layout]
        group_of = spec.group_of or (lambda run: "")
        oracle = (args.error or spec.error) == "oracle_err_deg"

        def error_of(run) -> str:
            return "oracle_err_deg" if oracle and run.protocol == "templates" else "err_deg"

        names = [f"{group_of(r)} / {x}".lstrip(" /") for r, x in zip(runs, run_labels(runs, labels, group_of))]
        table.notes += [""] + stability_notes(runs, names, args.stability, error_of)
    text = tables.RENDERERS[args.format](table)
    if out is None:
        print(text, end="")
    else:
        with out.writing() as path:
            atomic.write_text(path, text)
    return 2 if left_out else 0


if __name__ == "__main__":
    import sys

    from catpose.errors import CatposeError, command_error

    try:
        sys.exit(main())
    except CatposeError as e:
        print(command_error("table", e), file=sys.stderr)
        sys.exit(2)
