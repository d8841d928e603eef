"""``bench score``: predictions made elsewhere scored into a run directory like any run.

Learning-based methods (RPM-Net, Equi-pose, ...) need not be reimplemented: run them in their
own code on the same samples, write their poses to a file, and ``bench score`` turns the file
into a run directory scored with the same metrics, so ``bench table`` / ``bench report`` put
them beside ours.

The file formats are :mod:`catpose.bench.interop.prediction_io`'s; BOP ids map to samples as
:mod:`catpose.bench.interop.bop_export` documents; predictions are matched to a run's ground-truth
rows and scored as rows of ``samples.jsonl`` (:func:`score_predictions`), what was counted on the
way said (:func:`count_text`); on a BOP dataset, BOP's metrics of every target
(:mod:`catpose.bench.scoring.bop_eval`) are written beside the run (``bop_errors.jsonl``,
``bop_summary.md``: :func:`score_bop`).
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from catpose import atomic
from catpose.bench.interop.prediction_io import key_text, read_predictions
from catpose.bench.run.bop_ar import evaluation_models, has_bop_ids, is_bop_layout
from catpose.bench.run.overwrite import Input, Output, add_output_options
from catpose.bench.run.rundir import write_run_into
from catpose.bench.scoring.bop_eval import DEFAULT_METRICS as DEFAULT_BOP_METRICS
from catpose.errors import DatasetError, InvalidInputError


def score_predictions(
    preds,
    gt_rows: Sequence[dict],
    method: str,
    stats: dict | None = None,
) -> list[dict]:
    """Per-sample rows (``samples.jsonl`` schema) for the predictions against ground-truth rows
    (``gt_rows``, with ``T_gt``; one per view is enough). A view without a prediction is a failed row
    ("no prediction"): a miss. A BOP file's ids are those of the rows' ``info`` (runs on BOP-layout
    data); several instances of one object in an image are matched greedily as bop_toolkit does (by descending score, each taking the
    unmatched instance with the smallest ``err_deg``, then ``trans_err``). Duplicates and unknown ids
    follow docs/file-safety.md (a per-sample file's last row of an id counts; a BOP (image, object)
    keeps its best-scored estimates, one per instance). ``stats`` receives :func:`count_text`'s counts."""
    from catpose.bench.run.bop_ar import bop_key, template_camera_pose
    from catpose.bench.scoring.bop_eval import by_score, nearest_rotation
    from catpose.bench.scoring.metrics import sample_errors
    from catpose.bench.scoring.rows import failed_row, scored_row
    from catpose.geometry import make_T

    kind = preds.attrs.get("kind", "sample")
    all_by_key: dict[Any, list[dict]] = {}
    for p in preds.to_dict("records"):
        key = (int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"])) if kind == "bop" else str(p["sample_id"]).strip()
        all_by_key.setdefault(key, []).append(p)

    by_key = {k: v[-1] for k, v in all_by_key.items()}

    def estimate(p: dict, k: int) -> np.ndarray:
        T = np.asarray(p["T"], float)
        T = make_T(nearest_rotation(T[:3, :3]), T[:3, 3])
        return template_camera_pose(T, gt_rows[k].get("info") or {}) if kind == "bop" else T

    def errors_of(T_est: np.ndarray, g: dict) -> dict:
        axis, symmetries = g.get("symmetry_axis"), g.get("symmetries")
        return sample_errors(
            T_est,
            np.asarray(g["T_gt"], float).reshape(4, 4),
            None if axis is None else np.asarray(axis, float),
            symmetries if isinstance(symmetries, (list, tuple)) else (),
        )

    matched: dict[int, dict] = {}
    groups: dict[Any, list[int]] = {}
    if kind == "bop":
        for k, g in enumerate(gt_rows):
            groups.setdefault(bop_key(g.get("info") or {}), []).append(k)
        for key, members in groups.items():
            cands = by_score(all_by_key.get(key, []))
            free = list(members)
            for p in cands[: len(members)]:
                errs = {k: errors_of(estimate(p, k), gt_rows[k]) for k in free}
                best = min(free, key=lambda k: (round(errs[k]["err_deg"], 9), errs[k]["trans_err"]))
                matched[best] = p
                free.remove(best)
    out = []
    for k, g in enumerate(gt_rows):
        row = {
            key: g.get(key)
            for key in (
                "sample_id",
                "group_id",
                "obs_id",
                "category",
                "instance_id",
                "template_id",
                "dataset",
                "protocol",
                "seed",
                "symmetric",
                "T_gt",
                "symmetry_axis",
                "symmetries",
                "info",
            )
        }
        row.update(method=method, extras={}, stage="")
        if kind == "bop":
            p = matched.get(k)
        else:
            p = by_key.get(str(g["sample_id"])) or by_key.get(str(g.get("obs_id")))
        if p is None:
            out.append(failed_row(row, "no prediction", stage="register", score=None, runtime_s=None))
            continue
        T_est = estimate(p, k)
        score, rt = (
            None if x is None or not math.isfinite(float(x)) else float(x) for x in (p.get("score"), p.get("time"))
        )
        score = None if score is None else -score if kind == "bop" else score  # a BOP score is a confidence
        rt = rt if rt is not None and rt >= 0 else None  # BOP's -1: not measured
        out.append(scored_row(row, T_est, errors_of(T_est, g), score=score, runtime_s=rt))
    if stats is not None:
        stats.update(_counts(kind, all_by_key, gt_rows, groups, out))
    return out


def _counts(kind: str, all_by_key: dict, gt_rows: Sequence[dict], groups: dict, out: Sequence[dict]) -> dict:
    """The counts of :func:`score_predictions` (see :func:`count_text`)."""
    if kind == "bop":
        known = set(groups)
        wanted = {k: len(v) for k, v in groups.items()}
        ignored = sum(max(0, len(v) - wanted[k]) for k, v in all_by_key.items() if k in wanted)
        rule = "an (image, object) keeps its highest-scored estimates, one per instance"
    else:
        known = {str(g["sample_id"]) for g in gt_rows} | {str(g.get("obs_id")) for g in gt_rows}
        ignored = sum(len(v) - 1 for k, v in all_by_key.items() if k in known)
        rule = "the last row of a sample id counts"
    unknown = [k for k in all_by_key if k not in known]
    return {
        "predictions": sum(map(len, all_by_key.values())),
        "targets": len(gt_rows),
        "scored": sum(r["status"] == "ok" for r in out),
        "missing": sum(r["status"] != "ok" for r in out),
        "duplicates_ignored": ignored,
        "duplicate_rule": rule,
        "unknown_ids": len(unknown),
        "unknown_rows": sum(len(all_by_key[k]) for k in unknown),
        "unknown_examples": [key_text(k) for k in unknown[:5]],
    }


def count_text(stats: dict) -> str:
    """What a score counted, for people: scored, missing (misses), duplicates and unknown ids."""
    lines = [
        f"{stats['predictions']} prediction rows; {stats['scored']} of {stats['targets']} samples scored, "
        f"{stats['missing']} without a prediction (counted as misses: failed, 180 deg)"
    ]
    if stats["duplicates_ignored"]:
        lines.append(f"{stats['duplicates_ignored']} duplicate row(s) ignored ({stats['duplicate_rule']})")
    if stats["unknown_ids"]:
        lines.append(
            f"{stats['unknown_rows']} row(s) with {stats['unknown_ids']} id(s) that no sample has, ignored: "
            + ", ".join(stats["unknown_examples"])
            + (", ..." if stats["unknown_ids"] > 5 else "")
        )
    return "\n".join(lines)


def score_bop(
    preds,
    dataset_cfg: dict,
    out_dir: str | Path,
    method: str,
    vsd: bool = True,
) -> str:
    """BOP metrics of a BOP results CSV on the dataset of ``dataset_cfg`` (a resolved config
    dict): writes ``bop_errors.jsonl`` and ``bop_summary.md`` into ``out_dir`` and returns the
    summary: the recalls of :data:`DEFAULT_BOP_METRICS` per object and category (without VSD, no
    ``ar`` and ``ar_vsd``: BOP's AR needs it; other recalls: ``bench table --bop-metrics``), under
    the target and visibility filters applied and the models used (the dataset's ``models_eval/``
    when present, :func:`evaluation_models`)."""
    from catpose.bench.run.build import build_from_config
    from catpose.bench.scoring.bop_eval import ERRORS_FILE, compute_errors, format_scores, score_table, write_errors

    dataset_cfg = evaluation_models(dataset_cfg)
    _, ds = build_from_config(dict(dataset_cfg), "dataset")
    errs = compute_errors(preds, ds, vsd=vsd)
    ids = lambda rows: Counter((int(r["scene_id"]), int(r["im_id"]), int(r["obj_id"])) for r in rows)  # noqa: E731
    instances, estimates = ids(errs), ids(preds.to_dict("records"))
    filters = list(getattr(ds, "filters", [])) + [f"models: {dataset_cfg.get('models_dir', 'models')}/"]
    header = {
        "method": method,
        "filters": filters,
        "targets": len(errs),
        "matched": int(sum(r["matched"] for r in errs)),
        # ignored, and said so: estimates of no target, and those beyond an (image, object)'s instances
        "unknown_estimates": sum(n for k, n in estimates.items() if k not in instances),
        "extra_estimates": sum(max(0, n - instances[k]) for k, n in estimates.items() if k in instances),
    }
    write_errors(errs, Path(out_dir) / ERRORS_FILE, header)
    import pandas as pd

    metrics = [m for m in DEFAULT_BOP_METRICS if vsd or m not in ("ar", "ar_vsd")]
    text = f"BOP metrics ({method}):\n" + format_scores(score_table(pd.DataFrame(errs), metrics), header)
    atomic.write_text(Path(out_dir) / "bop_summary.md", text + "\n")
    return text


def gt_rows_from_run(run_dir: str | Path) -> tuple[list[dict], dict]:
    """Ground-truth rows (one per view) and the config of a run directory."""
    from catpose.bench.report.runs import load_run

    run = load_run(run_dir)
    if run.incomplete:  # its missing samples cannot be scored: said, not hidden
        import warnings

        warnings.warn(f"--gt: {run.incomplete}", stacklevel=2)
    s = run.samples
    if len(s) == 0 or "T_gt" not in s:
        raise DatasetError(f"run {run_dir} has no ground truth rows; pass a run written by `bench run`")
    n_rows = len(s)
    s = s[s["T_gt"].map(lambda v: isinstance(v, (list, np.ndarray)))]
    if len(s) == 0:
        raise DatasetError(
            f"run {run_dir} has no sample with ground truth ({n_rows} rows, all failed before their "
            "data loaded); pass a run whose samples loaded"
        )
    key = "group_id" if run.protocol in ("templates", "relative") else "sample_id"
    return s.drop_duplicates(key).to_dict("records"), run.config


def main(argv: list[str] | None = None) -> int:
    """``bench score PREDICTIONS.csv --gt RUN_DIR --method NAME --out DIR``."""
    ap = argparse.ArgumentParser(
        prog="bench score",
        description="Score an external predictions file (BOP CSV or per-sample CSV).",
    )
    ap.add_argument("predictions")
    ap.add_argument("--gt", help="a run directory whose ground truth (and samples) to score against")
    ap.add_argument(
        "--method",
        default=None,
        help="name of the external method (row label in tables; default: "
        "METHOD of a METHOD_DATASET-SPLIT.csv file name)",
    )
    add_output_options(ap, "run directory to write (new or empty; see --force)", force_help="replace a run at --out")
    ap.add_argument(
        "--no-vsd", action="store_true", help="BOP datasets: skip VSD (it renders the model twice per estimate)"
    )
    ap.add_argument(
        "--inverse",
        action="store_true",
        help="a per-sample CSV: its poses map the template onto the observation "
        "(T_camera_template); invert them (not for a BOP CSV, whose convention is fixed)",
    )
    args = ap.parse_args(argv)
    if not args.gt:
        raise InvalidInputError("pass --gt RUN_DIR: the run whose samples the predictions estimate")
    if args.method is None:
        from catpose.bench.scoring.bop_eval import check_results_filename

        try:
            args.method = check_results_filename(args.predictions)[0]
        except InvalidInputError:
            raise InvalidInputError(
                f"pass --method NAME (the file name {Path(args.predictions).name!r} is not METHOD_DATASET-SPLIT.csv)"
            ) from None
    # before any work: no input and no other run is written over (bench/run/overwrite.py), the --gt run never
    inputs = [Input(Path(args.predictions), "the predictions file"), Input(Path(args.gt), "the --gt run")]
    out = Output(args.out, "folder", inputs, args.force, replaces="run")
    preds = read_predictions(args.predictions, inverse=args.inverse)
    gt_rows, config = gt_rows_from_run(args.gt)
    if preds.attrs["kind"] == "bop" and not all(map(has_bop_ids, gt_rows)):
        raise InvalidInputError(
            f"{args.predictions} is a BOP results CSV, but the samples of run {args.gt} have no BOP ids (it is not "
            "on BOP-layout data); write the estimates as a per-sample CSV (sample_id,R,t)"
        )
    stats: dict = {}
    rows = score_predictions(preds, gt_rows, args.method, stats)
    if stats["predictions"] and not stats["scored"]:
        raise InvalidInputError(
            f"no prediction row of {args.predictions} names a sample of {args.gt} "
            f"(its ids look like {', '.join(stats['unknown_examples'][:2])}; the samples' like "
            f"{', '.join(r['sample_id'] for r in gt_rows[:2])}); score them against the run they estimate"
        )
    config = dict(config, method={"name": args.method, "external": str(args.predictions)})
    bop_text = None
    # the whole run directory is built beside --out and moved there when complete: a failure
    # leaves no half-written folder, and --force replaces the old one only then
    with out.writing(), atomic.building_dir(out.path) as tmp:
        write_run_into(tmp, rows, config, {"predictions": str(args.predictions), "counts": stats})
        if preds.attrs["kind"] == "bop" and is_bop_layout(config.get("dataset")):
            bop_text = score_bop(preds, config["dataset"], tmp, args.method, vsd=not args.no_vsd)
        summary = (tmp / "summary.md").read_text() if (tmp / "summary.md").is_file() else ""
    print(count_text(stats))
    print(f"run directory {out.path}")
    print(summary)
    if bop_text:
        print(bop_text)
    return 0
