"""Errors and summaries from a run directory's files (never from in-memory state).

Every table is scored through :func:`recompute_row_errors`: the errors of each row are recomputed
from its stored estimate and ground truth with the current metric definitions, so a metric fix
re-scores old runs without re-running them. :func:`summarize_run` writes ``samples.csv`` and
``summary.csv`` / ``.md`` over every finished sample of a run directory.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from catpose.bench.run.build import build_protocol
from catpose.bench.run.rundir import SAMPLES_FILE, latest_rows


def load_protocol(run_dir: Path) -> Any:
    """Rebuild the protocol of a run from its ``config.yaml`` (for scoring from files)."""
    from omegaconf import OmegaConf

    from catpose.bench.run.run_meta import read_config

    cfg = OmegaConf.create(read_config(Path(run_dir), required=True))
    if "protocol" not in cfg:
        from catpose.errors import DatasetError

        raise DatasetError(
            f"run {run_dir}: config.yaml has no protocol; re-run the same `bench run` command to rewrite it"
        )
    return build_protocol(cfg)


def recompute_row_errors(row: dict) -> dict:
    """A per-sample row with its errors recomputed from ``T_est``, ``T_gt``, ``symmetry_axis``
    and ``symmetries`` (the current metric definitions); a row without an estimate gets
    :data:`~catpose.bench.scoring.metrics.FAILED_ERROR_DEG`. Every table is scored through this."""
    from catpose.bench.scoring.metrics import FAILED_ERROR_DEG

    row = dict(row)
    T_est, T_gt = row.get("T_est"), row.get("T_gt")
    if row.get("status") == "ok" and isinstance(T_est, (list, np.ndarray)) and isinstance(T_gt, (list, np.ndarray)):
        row.update(row_errors(row, T_est, T_gt))
    else:
        row["err_deg"] = FAILED_ERROR_DEG
    return row


def row_errors(row: dict, T_est: Any, T_ref: Any) -> dict:
    """:func:`~catpose.bench.scoring.metrics.sample_errors` of ``T_est`` against ``T_ref`` (each
    (4, 4) or 16 numbers) under the symmetries a ``samples.jsonl`` row stores (``symmetry_axis``,
    ``symmetries``)."""
    from catpose.bench.scoring.metrics import sample_errors

    axis, symmetries = row.get("symmetry_axis"), row.get("symmetries")
    return sample_errors(
        np.reshape(T_est, (4, 4)),
        np.reshape(T_ref, (4, 4)),
        np.asarray(axis, float) if isinstance(axis, (list, np.ndarray)) else None,
        symmetries if isinstance(symmetries, (list, tuple)) else (),
    )


def summarize_run(run_dir: Path, sample_ids: Iterable[str] | None = None):
    """Per-category summary of a run from its files.

    Writes ``samples.csv`` and ``summary.csv``/``.md`` over every finished sample of the
    directory, so they always agree with ``samples.jsonl``. Returns that summary, or, when
    ``sample_ids`` is given (a ``limit``-ed run of a larger directory), the summary of those
    samples only (not written). Errors are recomputed from the stored estimates and ground
    truth, so the statistics never depend on in-memory state.
    """
    import pandas as pd

    from catpose import atomic

    run_dir = Path(run_dir)
    df = pd.DataFrame([recompute_row_errors(r) for r in latest_rows(run_dir / SAMPLES_FILE)])
    protocol = load_protocol(run_dir)
    if len(df):
        flat = df.drop(columns=[c for c in ("info", "extras", "symmetries") if c in df.columns]).copy()
        for c in ("T_est", "T_gt", "symmetry_axis"):
            if c in flat.columns:
                flat[c] = flat[c].map(
                    lambda v: " ".join(f"{x:.9g}" for x in np.ravel(v)) if isinstance(v, list) else ""
                )
        atomic.write_text(run_dir / "samples.csv", flat.to_csv(index=False))
    summary = _summary(df, protocol)
    atomic.write_text(run_dir / "summary.csv", summary.to_csv(index=False))
    atomic.write_text(run_dir / "summary.md", format_summary(summary) + "\n")
    if sample_ids is None or len(df) == 0:
        return summary
    wanted = set(sample_ids)
    return _summary(df[df["sample_id"].isin(wanted)].reset_index(drop=True), protocol)


def _summary(df, protocol):
    """Per-category statistics of per-sample rows scored by ``protocol``, oracle columns added
    for protocols that report one."""
    import pandas as pd

    from catpose.bench.scoring.metrics import summarize

    units = protocol.score_units(df) if len(df) else df
    if len(units) == 0:
        return summarize(pd.DataFrame(columns=["category", "status", "err_deg", "trans_err", "runtime_s"]))
    summary = summarize(units)
    if "oracle_err_deg" in units.columns:
        oracle = summarize(units.assign(err_deg=units["oracle_err_deg"], status="ok"))
        summary["oracle_mean_err_deg"] = oracle["mean_err_deg"].to_numpy()
        summary["oracle_median_err_deg"] = oracle["median_err_deg"].to_numpy()
    return summary


def format_summary(summary) -> str:
    """The summary as a Markdown table (angles in degrees, translation in object-normalised units)."""
    if len(summary) == 0:
        return "(no scored samples: none finished, or none has the ground truth this protocol scores)"
    return summary.to_markdown(index=False, floatfmt=".3f")


def evaluate_dir(run_dir: Path):
    """``bench evaluate`` of one run directory: its errors and summaries recomputed from its files
    (``samples.csv``, ``summary.csv`` / ``.md`` rewritten); returns the summary.

    A folder that is no run,
    an unreadable ``run.json`` or ``config.yaml``, or a ``samples.jsonl`` without rows is one
    :class:`~catpose.errors.DatasetError` line; a run that is still incomplete is summarized and
    said to be (a warning)."""
    import warnings

    from catpose.bench.run.overwrite import absolute_path, output_errors
    from catpose.bench.run.run_meta import incomplete_reason, read_config, read_run_json
    from catpose.errors import DatasetError

    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        absolute_path(run_dir)  # a loop of symbolic links: said as such
        raise DatasetError(
            f"{run_dir} is not a run directory (it does not exist); pass a folder written by `bench run`"
        )
    if not (run_dir / SAMPLES_FILE).is_file():
        what = f"{SAMPLES_FILE} is a folder, not a file" if (run_dir / SAMPLES_FILE).is_dir() else f"no {SAMPLES_FILE}"
        raise DatasetError(f"{run_dir} is not a run directory ({what}); pass a folder written by `bench run`")
    info = read_run_json(run_dir)  # an unreadable run.json or config.yaml: one line naming the run
    read_config(run_dir, required=True)
    rows = latest_rows(run_dir / SAMPLES_FILE)
    if not rows:
        raise DatasetError(f"run {run_dir} has no sample rows ({SAMPLES_FILE} is empty); re-run its `bench run`")
    why = incomplete_reason(run_dir, info, len(rows))
    if why:
        warnings.warn(why, stacklevel=2)
    with output_errors(run_dir, "the run directory"):
        return summarize_run(run_dir)


def main(argv: list[str]) -> int:
    """``bench evaluate RUN_DIR...``: recompute errors and summaries of run directories from their files."""
    import argparse

    parser = argparse.ArgumentParser(prog="bench evaluate", description=main.__doc__)
    parser.add_argument("run_dirs", nargs="+", type=Path, help="run directories (with samples.jsonl)")
    args = parser.parse_args(argv)
    for d in args.run_dirs:
        print(f"{d}:\n{format_summary(evaluate_dir(d))}\n")
    return 0
