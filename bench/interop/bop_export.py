"""``bench export``: a run's estimates as a BOP results CSV (bop_toolkit's format,
:mod:`catpose.bench.interop.prediction_io`), with the sample -> BOP id mapping beside it.

Mapping between samples and BOP ids. BOP datasets put ``scene_id``, ``im_id``, ``obj_id`` in each
sample's ``info`` (from ``Observation.info``), with ``scale_mm`` (millimetres per
object-normalised unit; ``mm_per_unit`` is read too) and optionally ``centre_mm`` (3,) and
``R_object_model`` (9, row-major) of the normalisation ``p_object = (R_object_model p_model -
centre_mm) / scale_mm`` (defaults: 0 and identity). With ``(R_co, t_co) = inv(T_template_camera_est)``:

    R_camera_model = R_co @ R_object_model,    t_camera_model[mm] = scale_mm * t_co - R_co @ centre_mm

Other datasets have no BOP ids; the export
then uses this documented mapping and writes it to ``<out>.map.csv``: ``obj_id`` = 1-based index
of the category in sorted order, ``scene_id`` = 1-based index of the instance within its
category (sorted), ``im_id`` = 0-based index of the observation within the instance (sorted
``obs_id``), ``scale_mm`` = 1 (translations stay in the object-normalised unit). ``bench score``
reads ``<predictions>.map.csv`` when it is there (or ``--map FILE``) and otherwise derives the
same ids from the ground-truth rows.
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


def bop_ids(runs_rows: Sequence[dict]) -> tuple[list[tuple], list[dict]]:
    """(scene_id, im_id, obj_id, scale_mm, centre_mm (3,), R_object_model (3, 3)) for each row,
    and the rows of the mapping file."""
    categories = sorted({str(r["category"]) for r in runs_rows})
    instances: dict[str, list[str]] = {}
    views: dict[tuple[str, str], list[str]] = {}
    for r in runs_rows:
        instances.setdefault(r["category"], [])
        if str(r.get("instance_id")) not in instances[r["category"]]:
            instances[r["category"]].append(str(r.get("instance_id")))
        views.setdefault((r["category"], str(r.get("instance_id"))), []).append(str(r.get("obs_id")))
    out, mapping = [], []
    for r in runs_rows:
        info = r.get("info") or {}
        if all(k in info for k in ("scene_id", "im_id", "obj_id")):
            ids = (int(info["scene_id"]), int(info["im_id"]), int(info["obj_id"]))
            scale = float(info.get("scale_mm", info.get("mm_per_unit", 1.0)))
            centre = np.asarray(info.get("centre_mm", info.get("model_centre_mm", [0.0, 0.0, 0.0])), float).reshape(3)
            R_om = np.asarray(info.get("R_object_model", np.eye(3)), float).reshape(3, 3)
        else:
            inst = str(r.get("instance_id"))
            ids = (
                sorted(instances[r["category"]]).index(inst) + 1,
                sorted(set(views[(r["category"], inst)])).index(str(r.get("obs_id"))),
                categories.index(r["category"]) + 1,
            )
            scale, centre, R_om = 1.0, np.zeros(3), np.eye(3)
        out.append((*ids, scale, centre, R_om))
        mapping.append(
            {
                "sample_id": r["sample_id"],
                "obs_id": r.get("obs_id"),
                "scene_id": ids[0],
                "im_id": ids[1],
                "obj_id": ids[2],
                "scale_mm": scale,
            }
        )
    return out, mapping


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


def export_bop(
    run_dir: str | Path, out_csv: str | Path, check_name: bool = True, skipped: list[str] | None = None
) -> int:
    """Write a run's estimates as a BOP results CSV (and ``<out_csv>.map.csv``, the sample -> BOP id
    mapping); returns the number of rows written. ``out_csv`` must be named
    ``METHOD_DATASET-SPLIT.csv`` (``check_name=False`` skips this). One row per scoring unit with an
    estimate (templates: the template the method chose); ``score`` is the confidence
    ``exp(-max(method score, 0))``, ``time`` one value per image (the summed runtimes, -1 if one is
    unknown). What is left out goes to ``skipped``; a run without any estimate is refused."""
    import pandas as pd

    from catpose.bench.protocols.relative import Relative
    from catpose.bench.report.tables import load_run, protocol_of
    from catpose.bench.scoring.bop_eval import check_results_filename
    from catpose.bench.scoring.bop_rows import camera_model_pose, confidence
    from catpose.errors import DatasetError, InvalidInputError

    run = load_run(run_dir)
    example = f"method_{_dataset_of(run) if _dataset_of(run) not in ('', 'bop') else 'ycbv'}-test.csv"
    if Path(out_csv).is_dir():
        raise InvalidInputError(
            f"--out {out_csv} is a folder; pass the CSV file to write, e.g. {Path(out_csv) / example}"
        )
    if check_name:
        check_results_filename(out_csv, example[7:-4])
        check_dataset_name(out_csv, run)
    if run.incomplete:  # exported all the same, and said
        log.warning("%s", run.incomplete)
    proto = protocol_of(run)
    units = proto.view_rows(run.samples) if isinstance(proto, Relative) else proto.score_units(run.samples)
    # ids over every view (failed ones too), so the mapping matches the scorer's, which sees all
    everything = units.to_dict("records")
    all_ids, all_mapping = bop_ids(everything)
    keep = [k for k, r in enumerate(everything) if r.get("status") == "ok" and r.get("T_est") is not None]
    rows, ids, mapping = [everything[k] for k in keep], [all_ids[k] for k in keep], [all_mapping[k] for k in keep]
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
    for r in rows:  # only poses are exported (a hand-edited samples.jsonl can hold anything)
        why = pose_problem(r["T_est"])
        if why:
            raise DatasetError(
                f"run {run_dir}: sample {r.get('sample_id')}: T_est {why}; its samples.jsonl is damaged: "
                "re-run that sample (delete its line and re-run the same command)"
            )
    times = image_times(ids, [r.get("runtime_s") for r in rows])
    lines = [",".join(BOP_COLUMNS)]
    for r, (scene, im, obj, *_) in zip(rows, ids):
        info = r.get("info") or {}  # without BOP ids: the documented mapping, in the object-normalised unit
        T = camera_model_pose(r["T_est"], info if all(k in info for k in ("scene_id", "im_id", "obj_id")) else {})
        R, t, conf = T[:3, :3], T[:3, 3], confidence(r.get("score"))
        rt = times[(scene, im)]
        lines.append(
            f"{scene},{im},{obj},{conf:.6g},{' '.join(f'{x:.9g}' for x in R.ravel())},"
            f"{' '.join(f'{x:.9g}' for x in t)},{rt:.6g}"
        )
    from catpose import atomic
    from catpose.bench.interop.prediction_io import read_predictions

    out_csv = Path(out_csv)
    with atomic.atomic_path(out_csv) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
        read_predictions(tmp)  # what bench score and bop_toolkit's loader check (ids, poses, one time per image)
    atomic.write_text(str(out_csv) + ".map.csv", pd.DataFrame(mapping).to_csv(index=False))
    return len(rows)


def pose_problem(T: Any) -> str | None:
    """Why a stored ``T_est`` is not a rigid transform (16 numbers, a rotation within
    :data:`~catpose.datasets.bop_layout.ROTATION_TOL`, a finite translation, last row
    ``[0, 0, 0, 1]``), None when it is one."""
    from catpose.datasets.bop_layout import rotation_problem

    a = np.asarray(T, dtype=object).reshape(-1)
    try:
        M = np.asarray(a, float)
    except (TypeError, ValueError):
        return "is not 16 numbers"
    if M.size != 16 or not np.isfinite(M).all():
        return f"is not 16 finite numbers ({M.size} values)"
    M = M.reshape(4, 4)
    if np.abs(M[3] - [0, 0, 0, 1]).max() > 1e-9:
        return f"has the last row {M[3].tolist()}, not [0, 0, 0, 1]"
    why = rotation_problem(M[:3, :3])
    return None if why is None else f"is not a rotation and translation ({why})"


def _dataset_of(run: Any) -> str:
    node = run.config.get("dataset")
    return str(node.get("name")) if isinstance(node, dict) and node.get("name") else str(run.info.get("dataset", ""))


def check_dataset_name(out_csv: str | Path, run: Any) -> None:
    """The ``DATASET`` of ``METHOD_DATASET-SPLIT.csv`` must be the run's dataset (the BOP toolkit
    scores the file against the dataset it names); a run of the generic ``dataset=bop`` config,
    whose name says nothing of the dataset, may be named as its user knows it."""
    from catpose.bench.scoring.bop_eval import check_results_filename
    from catpose.errors import InvalidInputError

    _, named, split = check_results_filename(out_csv)
    dataset = _dataset_of(run)
    if dataset and dataset != "bop" and named != dataset:
        method = Path(out_csv).name.split("_", 1)[0]
        raise InvalidInputError(
            f"--out {Path(out_csv).name} names dataset {named!r}, but run {run.path} is of dataset {dataset!r}; "
            f"name it {method}_{dataset}-{split}.csv"
        )


def main(argv: list[str] | None = None) -> int:
    """``bench export RUN_DIR --out METHOD_DATASET-SPLIT.csv``."""
    ap = argparse.ArgumentParser(prog="bench export", description="Export a run's estimates as a BOP results CSV.")
    ap.add_argument("run", help="a run directory written by `bench run`")
    from catpose.bench.run.overwrite import Input, Output, add_output_options

    add_output_options(
        ap,
        "CSV to write, named METHOD_DATASET-SPLIT.csv (no '_' in METHOD) as the BOP toolkit requires; a "
        "<out>.map.csv with the id mapping is written beside it",
        force_help="replace an existing --out and its .map.csv",
    )
    args = ap.parse_args(argv)
    inputs = [Input(Path(args.run), "the input run")]  # before any work (docs/file-safety.md)
    out = Output(args.out, "file", inputs, args.force, example="method_ycbv-test.csv")
    out_map = Output(str(args.out) + ".map.csv", "file", inputs, args.force)
    skipped: list[str] = []
    with out.writing(), out_map.writing():
        n = export_bop(args.run, args.out, skipped=skipped)
    for line in skipped:
        log.warning("skipped: %s", line)
    print(f"wrote {n} estimates to {args.out}")
    return 0
