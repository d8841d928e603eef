"""``bench score``: predictions made elsewhere scored into a run directory like any run.

Learning-based methods (RPM-Net, Equi-pose, ...) need not be reimplemented: run them in their
own code on the same samples, write their poses to a file, and ``bench score`` turns the file
into a run directory scored with the same metrics, so ``bench table`` / ``bench report`` put
them beside ours.

The file formats are :mod:`catpose.bench.interop.prediction_io`'s; BOP ids map to samples as
:mod:`catpose.bench.interop.bop_export` documents; predictions are matched to samples and scored by
:mod:`catpose.bench.interop.prediction_match`; on a BOP dataset, BOP's metrics of every target
(:mod:`catpose.bench.scoring.bop_eval`) are written beside the run (``bop_errors.jsonl``,
``bop_summary.md``: :func:`score_bop`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from catpose import atomic
from catpose.bench.interop.prediction_io import read_mapping, read_predictions
from catpose.bench.interop.prediction_match import count_text, score_predictions
from catpose.bench.run.overwrite import Input, Output, add_output_options
from catpose.bench.run.rundir import write_run_into
from catpose.bench.scoring.bop_rows import evaluation_models, is_bop_layout
from catpose.errors import DatasetError, InvalidInputError

DEFAULT_BOP_METRICS = ("ar", "ar_mssd", "ar_mspd", "ar_vsd", "adds@0.1", "5deg5cm", "10deg10cm")


def score_bop(
    preds,
    dataset_cfg: dict,
    out_dir: str | Path,
    method: str,
    metrics: Sequence[str],
    by: Sequence[str],
    vsd: bool = True,
) -> str:
    """BOP metrics of a BOP results CSV on the dataset of ``dataset_cfg`` (a resolved config
    dict): writes ``bop_errors.jsonl`` and ``bop_summary.md`` into ``out_dir`` and returns the
    summary (which states the target and visibility filters applied, and the models used: the
    dataset's ``models_eval/`` when present, :func:`evaluation_models`)."""
    from catpose.bench.run.build import build_from_config
    from catpose.bench.scoring.bop_eval import ERRORS_FILE, compute_errors, format_scores, score_table, write_errors

    dataset_cfg = evaluation_models(dataset_cfg)
    _, ds = build_from_config(dict(dataset_cfg), "dataset")
    errs = compute_errors(preds, ds, vsd=vsd)
    instances: dict[tuple, int] = {}
    for r in errs:
        key = (int(r["scene_id"]), int(r["im_id"]), int(r["obj_id"]))
        instances[key] = instances.get(key, 0) + 1
    estimates: dict[tuple, int] = {}
    for p in preds.to_dict("records"):
        key = (int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"]))
        estimates[key] = estimates.get(key, 0) + 1
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

    text = f"BOP metrics ({method}):\n" + format_scores(score_table(pd.DataFrame(errs), metrics, by), header)
    atomic.write_text(Path(out_dir) / "bop_summary.md", text + "\n")
    return text


def bop_metrics(asked: str | None, no_vsd: bool) -> str:
    """The BOP recalls to print: ``--metrics`` or :data:`DEFAULT_BOP_METRICS`; with ``--no-vsd``
    the defaults lose ``ar`` and ``ar_vsd`` (BOP's AR needs VSD), and asking for them is refused."""
    if asked is None:
        return ",".join(m for m in DEFAULT_BOP_METRICS if not (no_vsd and m in ("ar", "ar_vsd")))
    needs_vsd = [m for m in asked.split(",") if m.strip().lower() in ("ar", "ar_vsd")]
    if no_vsd and needs_vsd:
        raise InvalidInputError(
            f"--metrics {','.join(needs_vsd)} needs VSD, which --no-vsd skips (BOP's AR is the mean of ar_mssd, "
            "ar_mspd and ar_vsd); drop --no-vsd, or ask for ar_mssd,ar_mspd"
        )
    return asked


def gt_rows_from_run(run_dir: str | Path) -> tuple[list[dict], dict]:
    """Ground-truth rows (one per view) and the config of a run directory."""
    from catpose.bench.report.tables import load_run

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
            "data loaded); pass a run whose samples loaded, or --dataset NAME"
        )
    key = "group_id" if run.protocol in ("templates", "relative") else "sample_id"
    return s.drop_duplicates(key).to_dict("records"), run.config


def gt_rows_from_config(
    dataset: str, protocol: str, seed: int, overrides: Sequence[str] = ()
) -> tuple[list[dict], dict]:
    """Ground-truth rows built from ``configs/dataset/<dataset>.yaml`` + ``configs/protocol/<protocol>.yaml``."""
    from omegaconf import OmegaConf

    from catpose.bench.run.config import compose_and_build

    # one-line errors for an unknown name, a missing root etc.
    cfg, ((ds_name, ds), (pr_name, proto)) = compose_and_build(
        [f"dataset={dataset}", f"protocol={protocol}", f"seed={seed}", *overrides], ("dataset", "protocol")
    )
    config = OmegaConf.to_container(cfg, resolve=True)
    rows, seen = [], set()
    ids = list(cfg.sample_ids) if cfg.get("sample_ids") else proto.sample_ids(ds)
    for sid in ids[: cfg.limit] if cfg.get("limit") is not None else ids:
        sample = proto.load(ds, sid)
        group = sample.group_id or sid
        if group in seen and pr_name in ("templates", "relative"):
            continue
        seen.add(group)
        info = dict(sample.info)
        axis = sample.gt.symmetry_axis
        rows.append(
            {
                "sample_id": sid,
                "group_id": group,
                "obs_id": sid.split("|")[0],
                "category": sample.problem.category,
                "instance_id": info.get("instance_id"),
                "template_id": sample.problem.template.template_id,
                "dataset": ds_name,
                "protocol": pr_name,
                "seed": seed,
                "symmetric": axis is not None,
                "T_gt": np.asarray(sample.gt.T_template_camera, float).reshape(-1).tolist(),
                "symmetry_axis": None if axis is None else np.asarray(axis, float).tolist(),
                "symmetries": [np.asarray(S, float).reshape(-1).tolist() for S in sample.gt.symmetries] or None,
                "info": info,
            }
        )
    return rows, config


def main(argv: list[str] | None = None) -> int:
    """``bench score PREDICTIONS.csv --gt RUN_DIR --method NAME --out DIR`` (or ``--dataset D --protocol P``)."""
    ap = argparse.ArgumentParser(
        prog="bench score",
        description="Score an external predictions file (BOP CSV or per-sample CSV).",
    )
    ap.add_argument("predictions")
    ap.add_argument("--gt", help="a run directory whose ground truth (and samples) to score against")
    ap.add_argument("--dataset", help="or: a dataset config name (configs/dataset)")
    ap.add_argument("--protocol", default="gt_model", help="with --dataset: a protocol config name")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--override", action="append", default=[], help="extra Hydra override for --dataset, repeatable")
    ap.add_argument("--map", default=None, help="BOP id -> sample id CSV (default: <predictions>.map.csv if present)")
    ap.add_argument(
        "--method",
        default=None,
        help="name of the external method (row label in tables; default: "
        "METHOD of a METHOD_DATASET-SPLIT.csv file name)",
    )
    add_output_options(ap, "run directory to write (new or empty; see --force)", force_help="replace a run at --out")
    ap.add_argument(
        "--metrics",
        default=None,
        help="BOP datasets: comma-separated recalls, e.g. ar,ar_mssd,ar_mspd,ar_vsd,adds@0.1,add@0.1,mssd@0.2,"
        "mspd@10,5deg5cm,10deg10cm (default: " + ",".join(DEFAULT_BOP_METRICS) + "; without ar, ar_vsd with --no-vsd)",
    )
    ap.add_argument("--by", default="object,category", help="BOP datasets: rows per object and/or category")
    ap.add_argument(
        "--no-vsd", action="store_true", help="BOP datasets: skip VSD (it renders the model twice per estimate)"
    )
    ap.add_argument(
        "--inverse",
        action="store_true",
        help="a per-sample CSV: its poses map the template onto the observation "
        "(T_camera_template); invert them (not for a BOP CSV, whose convention is fixed)",
    )
    ap.add_argument(
        "--acc",
        default=None,
        metavar="LIST",
        help="also print accuracies at these thresholds, "
        "degrees and n-degree m-cm, e.g. --acc 5,10,30,5deg5cm,10deg10cm (summary_thresholds.md)",
    )
    ap.add_argument(
        "--auc",
        type=float,
        default=None,
        metavar="DEG",
        help="also print the area under the accuracy curve from 0 to DEG degrees, over DEG",
    )
    args = ap.parse_args(argv)
    args.metrics = bop_metrics(args.metrics, args.no_vsd)
    if args.auc is not None and not 0 < args.auc <= 180:
        raise InvalidInputError(f"--auc {args.auc:g}: pass an angle in degrees in (0, 180], e.g. --auc 30")
    if not args.by or set(args.by.split(",")) - {"object", "category"}:
        raise InvalidInputError(f"--by {args.by!r}: pass object, category or object,category (BOP rows)")
    if args.method is None:
        from catpose.bench.scoring.bop_eval import check_results_filename

        try:
            args.method = check_results_filename(args.predictions)[0]
        except InvalidInputError:
            raise InvalidInputError(
                f"pass --method NAME (the file name {Path(args.predictions).name!r} is not METHOD_DATASET-SPLIT.csv)"
            ) from None
    if bool(args.gt) == bool(args.dataset):
        raise InvalidInputError("pass exactly one of --gt RUN_DIR or --dataset NAME")
    # before any work: no input and no other run is written over (bench/run/overwrite.py), the --gt run never
    inputs = [Input(Path(args.predictions), "the predictions file")]
    inputs += [Input(Path(p), what) for p, what in ((args.gt, "the --gt run"), (args.map, "the --map file")) if p]
    out = Output(args.out, "folder", inputs, args.force, replaces="run")
    if args.inverse:
        check_inverse_csv(args.predictions)
    gt_rows, config = (
        gt_rows_from_run(args.gt)
        if args.gt
        else gt_rows_from_config(args.dataset, args.protocol, args.seed, args.override)
    )
    preds = read_predictions(args.predictions, inverse=args.inverse)
    map_path = Path(args.map) if args.map else Path(str(args.predictions) + ".map.csv")
    if args.map and not map_path.is_file():
        raise InvalidInputError(f"--map {map_path} does not exist")
    mapping = read_mapping(map_path) if preds.attrs["kind"] == "bop" and map_path.is_file() else None
    stats: dict = {}
    rows = score_predictions(preds, gt_rows, args.method, mapping, stats)
    if stats["predictions"] and not stats["scored"]:
        raise InvalidInputError(
            f"no prediction row of {args.predictions} names a sample of {args.gt or 'dataset=' + args.dataset} "
            f"(its ids look like {', '.join(stats['unknown_examples'][:2])}; the samples' like "
            f"{', '.join(r['sample_id'] for r in gt_rows[:2])}); score them against the run or dataset they estimate"
        )
    config = dict(config, method={"name": args.method, "external": str(args.predictions)})
    bop_text = None
    # the whole run directory is built beside --out and moved there when complete: a failure
    # leaves no half-written folder, and --force replaces the old one only then
    thresholds = None
    with out.writing(), atomic.building_dir(out.path) as tmp:
        write_run_into(tmp, rows, config, {"predictions": str(args.predictions), "counts": stats})
        if preds.attrs["kind"] == "bop" and is_bop_layout(config.get("dataset")):
            bop_text = score_bop(
                preds,
                config["dataset"],
                tmp,
                args.method,
                args.metrics.split(","),
                args.by.split(","),
                vsd=not args.no_vsd,
            )
        objects = _object_summary(rows, tmp)
        summary = (tmp / "summary.md").read_text() if (tmp / "summary.md").is_file() else ""
        if args.acc or args.auc is not None:
            thresholds = _threshold_summary(rows, tmp, args.acc or "", args.auc)
    print(count_text(stats))
    print(f"run directory {out.path}")
    print(summary)
    print(objects)
    if thresholds is not None:
        print(thresholds)
    if bop_text:
        print(bop_text)
    return 0


def check_inverse_csv(path: str | Path) -> None:
    """``--inverse`` applies to per-sample files only: a BOP results CSV's poses are
    ``T_camera_model`` by definition, so inverting them is refused rather than ignored."""
    first = ""
    if Path(path).is_file():
        with open(path, encoding="utf-8", errors="replace") as fh:
            first = next((ln for ln in fh if ln.strip()), "")
    if {"scene_id", "im_id", "obj_id"} <= {c.strip() for c in first.split(",")}:
        raise InvalidInputError(
            f"--inverse: {path} is a BOP results CSV, whose R, t are T_camera_model by definition; drop "
            "--inverse (it applies to per-sample CSVs)"
        )


def _object_summary(rows: Sequence[dict], out_dir: Path) -> str:
    """Per-object rows of the same statistics as ``summary.md`` (written to ``summary_objects.md``)."""
    import pandas as pd

    from catpose.bench.run.evaluate import format_summary
    from catpose.bench.scoring.metrics import summarize

    df = pd.DataFrame(list(rows))
    df["object"] = [f"{c}/{i}" for c, i in zip(df["category"], df["instance_id"])]
    text = format_summary(summarize(df, by="object"))
    atomic.write_text(Path(out_dir) / "summary_objects.md", text + "\n")
    return text


def _threshold_summary(rows: Sequence[dict], out_dir: Path, acc: str, auc: float | None) -> str:
    """``--acc`` / ``--auc``: per category, the accuracies and AUC of
    :mod:`catpose.bench.scoring.curves` (written to ``summary_thresholds.md``)."""
    import pandas as pd

    from catpose.bench.scoring.curves import threshold_keys, threshold_table

    keys = threshold_keys(acc, auc)
    text = threshold_table(pd.DataFrame(list(rows)), keys).to_markdown(index=False, floatfmt=".3f")
    atomic.write_text(Path(out_dir) / "summary_thresholds.md", text + "\n")
    return text
