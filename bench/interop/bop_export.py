"""``bench export``: the estimates of a run on BOP-layout data as a BOP results CSV (bop_toolkit's
format, :mod:`catpose.bench.interop.prediction_io`).

BOP datasets put ``scene_id``, ``im_id``, ``obj_id`` in each sample's ``info`` (from
``Observation.info``), with the object's normalisation (``scale_mm``, ``centre_mm``,
``R_object_model``) that takes an estimate to BOP's ``T_camera_model`` in millimetres
(:func:`catpose.bench.run.bop_ar.camera_model_pose`). Runs on other datasets have no BOP ids: an
external method's estimates of them are scored from a per-sample CSV.
"""

from __future__ import annotations

import argparse
import logging
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from catpose.bench.interop.prediction_io import BOP_COLUMNS

log = logging.getLogger(__name__)


def image_times(ids: Sequence[tuple], runtimes: Sequence[Any]) -> dict[tuple[int, int], float]:
    """One time per image (bop_toolkit's ``check_consistent_timings``): the sum of the
    runtimes (s) of the image's estimates, -1 when any of them is unknown. ``ids`` start with
    ``(scene_id, im_id, ...)``."""
    out: dict[tuple[int, int], float] = {}
    for i, rt in zip(ids, runtimes):
        key = (int(i[0]), int(i[1]))
        known = rt is not None and math.isfinite(float(rt)) and float(rt) >= 0
        if out.get(key, 0.0) < 0 or not known:
            out[key] = -1.0
        else:
            out[key] = out.get(key, 0.0) + float(rt)
    return out


def export_bop(run_dir: str | Path, out_csv: str | Path, skipped: list[str] | None = None) -> int:
    """Write the estimates of a run on BOP-layout data as a BOP results CSV; returns the number of
    rows written. ``out_csv`` must be named ``METHOD_DATASET-SPLIT.csv`` with the run's DATASET (the
    BOP toolkit scores the file against the dataset it names; a run of the generic ``dataset=bop``
    config may name it as its user knows it). One row per scoring unit with an estimate (templates: the template the method chose);
    ``score`` is the confidence ``exp(-max(method score, 0))``, ``time`` one value per image (the
    summed runtimes, -1 if one is unknown). What is left out goes to ``skipped``; a run without any
    estimate, or whose samples have no BOP ids, is refused."""
    from catpose.bench.protocols.relative import Relative
    from catpose.bench.report.runs import load_run, protocol_of
    from catpose.bench.run.bop_ar import has_bop_ids, predictions_from_units
    from catpose.bench.scoring.bop_eval import check_results_filename
    from catpose.errors import DatasetError, InvalidInputError

    run = load_run(run_dir)
    node = run.config.get("dataset")
    dataset = str(node.get("name")) if isinstance(node, dict) and node.get("name") else str(run.info.get("dataset", ""))
    example = f"method_{dataset if dataset not in ('', 'bop') else 'ycbv'}-test.csv"
    if Path(out_csv).is_dir():
        raise InvalidInputError(
            f"--out {out_csv} is a folder; pass the CSV file to write, e.g. {Path(out_csv) / example}"
        )
    method, named, split = check_results_filename(out_csv, example[7:-4])
    if dataset and dataset != "bop" and named != dataset:
        raise InvalidInputError(
            f"--out {Path(out_csv).name} names dataset {named!r}, but run {run.path} is of dataset {dataset!r}; "
            f"name it {method}_{dataset}-{split}.csv"
        )
    if run.incomplete:  # exported all the same, and said
        log.warning("%s", run.incomplete)
    proto = protocol_of(run)
    units = proto.view_rows(run.samples) if isinstance(proto, Relative) else proto.score_units(run.samples)
    everything = units.to_dict("records")
    rows = [r for r in everything if r.get("status") == "ok" and r.get("T_est") is not None]
    failed = [r for r in everything if not (r.get("status") == "ok" and r.get("T_est") is not None)]
    if not rows:
        raise DatasetError(
            f"run {run_dir} has no sample with an estimate ({len(everything)} samples, all failed); "
            "nothing to export: re-run the method (bench run ... retry_failed=true)"
        )
    if failed and skipped is not None:
        skipped.append(
            f"{len(failed)} of {len(everything)} samples have no estimate (failed) and are not in the "
            f"file, e.g. {failed[0].get('sample_id')}: {str(failed[0].get('error') or '')[:80]}"
        )
    if not all(has_bop_ids(r) for r in rows):
        raise InvalidInputError(
            f"run {run_dir} is not on BOP-layout data (dataset {dataset or '?'}): its samples have no BOP "
            "ids to export; score another method's estimates of it from a per-sample CSV (docs/evaluation.md)"
        )
    for r in rows:  # only poses are exported (a hand-edited samples.jsonl can hold anything)
        why = pose_problem(r["T_est"])
        if why:
            raise DatasetError(
                f"run {run_dir}: sample {r.get('sample_id')}: T_est {why}; its samples.jsonl is damaged: "
                "re-run that sample (delete its line and re-run the same command)"
            )
    preds = predictions_from_units(rows).to_dict("records")  # what bench score reads back
    times = image_times([(p["scene_id"], p["im_id"]) for p in preds], [r.get("runtime_s") for r in rows])
    lines = [",".join(BOP_COLUMNS)]
    for p in preds:
        R, t = p["T"][:3, :3], p["T"][:3, 3]
        lines.append(
            f"{p['scene_id']},{p['im_id']},{p['obj_id']},{p['score']:.6g},{' '.join(f'{x:.9g}' for x in R.ravel())},"
            f"{' '.join(f'{x:.9g}' for x in t)},{times[(p['scene_id'], p['im_id'])]:.6g}"
        )
    from catpose import atomic
    from catpose.bench.interop.prediction_io import read_predictions

    with atomic.atomic_path(Path(out_csv)) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
        read_predictions(tmp)  # what bench score and bop_toolkit's loader check (ids, poses, one time per image)
    return len(rows)


def pose_problem(T: Any) -> str | None:
    """Why a stored ``T_est`` (16 numbers, as :mod:`catpose.bench.run.rows_file` reads every row) is
    not a rigid transform (finite, a rotation within :data:`~catpose.datasets.bop_layout.ROTATION_TOL`,
    last row ``[0, 0, 0, 1]``), None when it is one."""
    from catpose.datasets.bop_layout import rotation_problem

    M = np.asarray(T, float).reshape(4, 4)
    if not np.isfinite(M).all():
        return "has a NaN or infinite value"
    if np.abs(M[3] - [0, 0, 0, 1]).max() > 1e-9:
        return f"has the last row {M[3].tolist()}, not [0, 0, 0, 1]"
    why = rotation_problem(M[:3, :3])
    return None if why is None else f"is not a rotation and translation ({why})"


def main(argv: list[str] | None = None) -> int:
    """``bench export RUN_DIR --out METHOD_DATASET-SPLIT.csv``."""
    ap = argparse.ArgumentParser(prog="bench export", description="Export a run's estimates as a BOP results CSV.")
    ap.add_argument("run", help="a run directory written by `bench run`")
    from catpose.bench.run.overwrite import Input, Output, add_output_options

    add_output_options(
        ap,
        "CSV to write, named METHOD_DATASET-SPLIT.csv (no '_' in METHOD) as the BOP toolkit requires",
        force_help="replace an existing --out",
    )
    args = ap.parse_args(argv)
    inputs = [Input(Path(args.run), "the input run")]  # before any work (docs/file-safety.md)
    out = Output(args.out, "file", inputs, args.force, example="method_ycbv-test.csv")
    skipped: list[str] = []
    with out.writing():
        n = export_bop(args.run, args.out, skipped=skipped)
    for line in skipped:
        log.warning("skipped: %s", line)
    print(f"wrote {n} estimates to {args.out}")
    return 0
