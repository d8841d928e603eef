"""External predictions: export a run as a BOP results CSV, and score predictions made elsewhere.

Learning-based methods (RPM-Net, Equi-pose, ...) need not be reimplemented: run them in their
own code on the same samples, write their poses to a file, and ``bench score`` turns the file
into a run directory scored with the same metrics, so ``bench table`` / ``bench report`` put
them beside ours.

Two file formats are read (detected from the header):

- **BOP results CSV** (``scene_id,im_id,obj_id,score,R,t,time``; bop_toolkit's format). ``R`` is
  ``R_camera_model`` (BOP's ``cam_R_m2c``), 9 space-separated row-major values; ``t`` is
  ``t_camera_model`` in millimetres; ``score`` is a confidence (higher is better); ``time`` in
  seconds, one value per image (-1 when unknown). Several rows of one image and object are
  matched to that object's instances greedily by score (as bop_toolkit does); files must be
  named ``METHOD_DATASET-SPLIT.csv`` for the toolkit. For BOP datasets ``bench score`` also
  computes BOP's metrics (MSSD, MSPD, VSD, ADD(-S), n-degree m-cm; :mod:`catpose.bench.scoring.bop_eval`)
  on the split's official targets with gt instances at ``visib_fract >= 0.1``.
- **Per-sample CSV** (``sample_id,R,t[,score][,time]``): ``R``/``t`` of ``T_template_camera``
  (this project's convention: camera points into the template frame) in the object-normalised
  unit; ``sample_id`` is a run's sample id or observation id (``obs_id``).

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
import json
import math
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from catpose.errors import CatposeError, DatasetError, InvalidInputError

BOP_COLUMNS = ["scene_id", "im_id", "obj_id", "score", "R", "t", "time"]


# --------------------------------------------------------------------------------------------
# Writing run directories


def write_run(out_dir: str | Path, rows: Sequence[dict], config: dict, info: dict | None = None) -> Path:
    """Write a run directory (``samples.jsonl``, ``config.yaml``, ``run.json``, summaries).

    ``rows`` follow the ``samples.jsonl`` schema; ``config`` is a plain dict with at least
    ``method``, ``dataset``, ``protocol`` (config-group dicts with ``name`` and ``_target_``)
    and ``seed``. Returns ``out_dir``.
    """
    from omegaconf import OmegaConf

    from catpose.bench.run.evaluate import summarize_run
    from catpose.bench.run.rundir import SAMPLES_FILE, SampleWriter

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / SAMPLES_FILE).unlink(missing_ok=True)
    writer = SampleWriter(out / SAMPLES_FILE)
    try:
        for r in rows:
            writer.write(r)
    finally:
        writer.close()
    OmegaConf.save(OmegaConf.create(config), out / "config.yaml")
    meta = {"method": _name(config.get("method")), "dataset": _name(config.get("dataset")),
            "protocol": _name(config.get("protocol")), "seed": config.get("seed"), "n_samples": len(rows)}
    (out / "run.json").write_text(json.dumps(dict(meta, **(info or {})), indent=2) + "\n")
    (out / "git_rev.txt").write_text("external predictions\n")
    if rows:
        summarize_run(out)
    return out


def _name(node: Any) -> str:
    return str(node.get("name")) if isinstance(node, dict) else str(node)


# --------------------------------------------------------------------------------------------
# Export


def _bop_ids(runs_rows: Sequence[dict]) -> tuple[list[tuple], list[dict]]:
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
            ids = (sorted(instances[r["category"]]).index(inst) + 1,
                   sorted(set(views[(r["category"], inst)])).index(str(r.get("obs_id"))),
                   categories.index(r["category"]) + 1)
            scale, centre, R_om = 1.0, np.zeros(3), np.eye(3)
        out.append((*ids, scale, centre, R_om))
        mapping.append({"sample_id": r["sample_id"], "obs_id": r.get("obs_id"), "scene_id": ids[0],
                        "im_id": ids[1], "obj_id": ids[2], "scale_mm": scale})
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


def export_bop(run_dir: str | Path, out_csv: str | Path, check_name: bool = True) -> int:
    """Write a run's estimates as a BOP results CSV; returns the number of rows written.

    ``out_csv`` must be named ``METHOD_DATASET-SPLIT.csv`` (no ``_`` in METHOD) as the BOP
    toolkit requires (``check_name=False`` skips this, e.g. for non-BOP datasets). ``time`` is
    one value per image: the summed runtimes of all the image's estimates (-1 if one is unknown).

    Uses the run's scoring units of one view each (for the templates protocol: the template the
    method chose), skips failed samples, and writes ``<out_csv>.map.csv`` with the sample ->
    BOP id mapping. ``score`` is ``exp(-max(method score, 0))``, a confidence in (0, 1] (1 when
    the method has no score; every built-in method's score is a non-negative loss).
    """
    import pandas as pd

    from catpose.bench.protocols.relative import Relative
    from catpose.bench.report.tables import load_run, protocol_of
    from catpose.bench.scoring.bop_eval import check_results_filename
    from catpose.geometry import invert_T

    if check_name:
        check_results_filename(out_csv)
    run = load_run(run_dir)
    proto = protocol_of(run)
    units = proto.view_rows(run.samples) if isinstance(proto, Relative) else proto.score_units(run.samples)
    # ids over every view (failed ones too), so the mapping matches the scorer's, which sees all
    everything = units.to_dict("records")
    all_ids, all_mapping = _bop_ids(everything)
    keep = [k for k, r in enumerate(everything) if r.get("status") == "ok" and r.get("T_est") is not None]
    rows, ids, mapping = [everything[k] for k in keep], [all_ids[k] for k in keep], [all_mapping[k] for k in keep]
    times = image_times(ids, [r.get("runtime_s") for r in rows])
    lines = [",".join(BOP_COLUMNS)]
    for r, (scene, im, obj, scale, centre, R_om) in zip(rows, ids):
        T_co = invert_T(np.asarray(r["T_est"], float).reshape(4, 4))
        R = T_co[:3, :3] @ R_om
        t = scale * T_co[:3, 3] - T_co[:3, :3] @ centre
        s = r.get("score")
        conf = 1.0 if s is None or not math.isfinite(float(s)) else math.exp(-max(float(s), 0.0))
        rt = times[(scene, im)]
        lines.append(f"{scene},{im},{obj},{conf:.6g},{' '.join(f'{x:.9g}' for x in R.ravel())},"
                     f"{' '.join(f'{x:.9g}' for x in t)},{rt:.6g}")
    out_csv = Path(out_csv)
    out_csv.parent.mkdir(parents=True, exist_ok=True)
    out_csv.write_text("\n".join(lines) + "\n")
    from catpose.bench.scoring.bop_eval import check_results_csv

    check_results_csv(out_csv)  # what bop_toolkit's loader checks (header, ids, one time per image)
    pd.DataFrame(mapping).to_csv(str(out_csv) + ".map.csv", index=False)
    return len(rows)


# --------------------------------------------------------------------------------------------
# Reading and scoring


def _floats(text: Any, n: int, where: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in str(text).replace(",", " ").split()], float)
    except ValueError:
        v = np.array([])
    if v.shape != (n,) or not np.isfinite(v).all():
        raise InvalidInputError(f"{where}: expected {n} space-separated numbers, got {str(text)[:60]!r}")
    return v


def read_predictions(path: str | Path):
    """Read a BOP or per-sample predictions CSV into a DataFrame with a ``T`` column.

    ``T`` is the file's (4, 4) pose as written (BOP: ``T_camera_model`` in mm; per-sample:
    ``T_template_camera``); ``kind`` is ``"bop"`` or ``"sample"``.
    """
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"predictions file {path} does not exist")
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    cols = set(df.columns)
    if {"scene_id", "im_id", "obj_id", "R", "t"} <= cols:
        kind = "bop"
    elif {"sample_id", "R", "t"} <= cols:
        kind = "sample"
    else:
        raise InvalidInputError(f"{path}: header {list(df.columns)} is neither BOP (scene_id,im_id,obj_id,score,R,t,time) "
                                "nor per-sample (sample_id,R,t[,score][,time])")
    Ts = []
    for k, r in enumerate(df.to_dict("records"), 2):
        T = np.eye(4)
        T[:3, :3] = _floats(r["R"], 9, f"{path}:{k} R").reshape(3, 3)
        T[:3, 3] = _floats(r["t"], 3, f"{path}:{k} t")
        Ts.append(T)
    df["T"] = Ts
    df["score"] = pd.to_numeric(df["score"], errors="coerce") if "score" in df else np.nan
    df["time"] = pd.to_numeric(df["time"], errors="coerce") if "time" in df else np.nan
    df.attrs["kind"] = kind
    return df


def _orthonormalise(R: np.ndarray) -> np.ndarray:
    """Nearest rotation (files hold rounded values)."""
    U, _, Vt = np.linalg.svd(R)
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt


def read_mapping(path: str | Path) -> dict[tuple[int, int, int], str]:
    """An export's ``<out>.map.csv``: (scene_id, im_id, obj_id) -> sample_id. Ids shared by
    several samples (several instances of one object in an image) are left out: those are
    matched greedily by score."""
    import pandas as pd

    df = pd.read_csv(path, dtype={"sample_id": str})
    keys = [(int(r.scene_id), int(r.im_id), int(r.obj_id)) for r in df.itertuples()]
    counts: dict[tuple, int] = {}
    for k in keys:
        counts[k] = counts.get(k, 0) + 1
    return {k: str(sid) for k, sid in zip(keys, df["sample_id"]) if counts[k] == 1}


def score_predictions(preds, gt_rows: Sequence[dict], method: str,
                      mapping: dict[tuple[int, int, int], str] | None = None) -> list[dict]:
    """Per-sample rows (``samples.jsonl`` schema) for the predictions against ground-truth rows.

    ``gt_rows`` are rows with ``T_gt`` (a run's ``samples.jsonl``, one per view is enough). A
    view without a prediction is recorded as failed ("no prediction"). For a BOP file,
    ``mapping`` ((scene_id, im_id, obj_id) -> sample_id, from the export's ``.map.csv``) takes
    precedence over the ids derived from the rows. Without it, where several gt rows share
    (scene_id, im_id, obj_id) (several instances of one object in an image), the estimates are
    matched greedily as bop_toolkit does: in descending score order, each takes the unmatched
    instance with the smallest ``err_deg`` (then ``trans_err``); extra estimates are ignored.
    """
    from catpose.bench.scoring.metrics import sample_errors
    from catpose.bench.run.rundir import failed_row, scored_row
    from catpose.geometry import invert_T, make_T

    kind = preds.attrs.get("kind", "sample")
    by_key: dict[Any, dict] = {}
    all_by_key: dict[Any, list[dict]] = {}
    for p in preds.to_dict("records"):
        key = (int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"])) if kind == "bop" else str(p["sample_id"])
        all_by_key.setdefault(key, []).append(p)
        old = by_key.get(key)
        if old is None or (kind == "bop" and np.nan_to_num(p["score"], nan=-np.inf) > np.nan_to_num(old["score"], nan=-np.inf)):
            by_key[key] = p
    ids = _bop_ids(gt_rows)[0] if kind == "bop" else None
    if kind == "bop" and mapping:
        by_sample = {mapping[k]: p for k, p in by_key.items() if k in mapping}

    def estimate(p: dict, k: int) -> np.ndarray:
        T = np.asarray(p["T"], float)
        R = _orthonormalise(T[:3, :3])
        if kind != "bop":
            return make_T(R, T[:3, 3])
        _, _, _, scale, centre, R_om = ids[k]  # T_camera_model[mm] -> T_template_camera[unit]
        R_co = R @ R_om.T
        return invert_T(make_T(R_co, (T[:3, 3] + R_co @ centre) / scale))

    def errors_of(T_est: np.ndarray, g: dict) -> dict:
        axis, symmetries = g.get("symmetry_axis"), g.get("symmetries")
        return sample_errors(T_est, np.asarray(g["T_gt"], float).reshape(4, 4),
                             None if axis is None else np.asarray(axis, float),
                             symmetries if isinstance(symmetries, (list, tuple)) else ())

    matched: dict[int, dict] = {}
    if kind == "bop":
        groups: dict[tuple, list[int]] = {}
        for k in range(len(gt_rows)):
            groups.setdefault(ids[k][:3], []).append(k)
        for key, members in groups.items():
            cands = sorted(all_by_key.get(key, []), key=lambda p: -np.nan_to_num(float(p["score"]), nan=-np.inf))
            free = list(members)
            for p in cands[:len(members)]:
                errs = {k: errors_of(estimate(p, k), gt_rows[k]) for k in free}
                best = min(free, key=lambda k: (round(errs[k]["err_deg"], 9), errs[k]["trans_err"]))
                matched[best] = p
                free.remove(best)
    out = []
    for k, g in enumerate(gt_rows):
        row = {key: g.get(key) for key in ("sample_id", "group_id", "obs_id", "category", "instance_id", "template_id",
                                           "dataset", "protocol", "seed", "symmetric", "T_gt", "symmetry_axis", "symmetries",
                                           "info")}
        row.update(method=method, extras={}, stage="")
        if kind == "bop":
            sid = str(g["sample_id"])
            p = by_sample[sid] if mapping and sid in by_sample else matched.get(k)
        else:
            p = by_key.get(str(g["sample_id"])) or by_key.get(str(g.get("obs_id")))
        if p is None:
            out.append(failed_row(row, "no prediction", stage="register", score=None, runtime_s=None))
            continue
        T_est = estimate(p, k)
        errs = errors_of(T_est, g)
        score = p.get("score")
        score = None if score is None or not math.isfinite(float(score)) else (-float(score) if kind == "bop" else float(score))
        rt = p.get("time")
        out.append(scored_row(row, T_est, errs, score=score,
                              runtime_s=None if rt is None or not math.isfinite(float(rt)) or float(rt) < 0 else float(rt)))
    return out


def gt_rows_from_run(run_dir: str | Path) -> tuple[list[dict], dict]:
    """Ground-truth rows (one per view) and the config of a run directory."""
    from catpose.bench.report.tables import load_run

    run = load_run(run_dir)
    s = run.samples
    if len(s) == 0 or "T_gt" not in s:
        raise DatasetError(f"run {run_dir} has no ground truth rows; pass a run written by `bench run`")
    s = s[s["T_gt"].notna()]
    key = "group_id" if run.protocol in ("templates", "relative") else "sample_id"
    return s.drop_duplicates(key).to_dict("records"), run.config


def gt_rows_from_config(dataset: str, protocol: str, seed: int, overrides: Sequence[str] = ()) -> tuple[list[dict], dict]:
    """Ground-truth rows built from ``configs/dataset/<dataset>.yaml`` + ``configs/protocol/<protocol>.yaml``."""
    from hydra import compose, initialize_config_module
    from omegaconf import OmegaConf

    from catpose.bench.run.command import check_overrides
    from catpose.bench.run.build import build_from_config

    check_overrides([f"dataset={dataset}", f"protocol={protocol}"])
    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose("run", overrides=[f"dataset={dataset}", f"protocol={protocol}", f"seed={seed}", *overrides])
    ds_name, ds = build_from_config(cfg.dataset, "dataset")  # one-line errors for a missing root etc.
    pr_name, proto = build_from_config(cfg.protocol, "protocol")
    config = OmegaConf.to_container(cfg, resolve=True)
    ds.name = ds_name
    rows, seen = [], set()
    for sid in proto.sample_ids(ds):
        sample = proto.load(ds, sid)
        group = sample.group_id or sid
        if group in seen and pr_name in ("templates", "relative"):
            continue
        seen.add(group)
        info = dict(sample.info)
        axis = sample.gt.symmetry_axis
        rows.append({"sample_id": sid, "group_id": group, "obs_id": sid.split("|")[0], "category": sample.problem.category,
                     "instance_id": info.get("instance_id"), "template_id": sample.problem.template.template_id,
                     "dataset": ds_name, "protocol": pr_name, "seed": seed, "symmetric": axis is not None,
                     "T_gt": np.asarray(sample.gt.T_template_camera, float).reshape(-1).tolist(),
                     "symmetry_axis": None if axis is None else np.asarray(axis, float).tolist(),
                     "symmetries": [np.asarray(S, float).reshape(-1).tolist() for S in sample.gt.symmetries] or None,
                     "info": info})
    return rows, config


def export_main(argv: list[str] | None = None) -> int:
    """``bench export RUN_DIR --out METHOD_DATASET-SPLIT.csv``."""
    ap = argparse.ArgumentParser(prog="bench export", description="Export a run's estimates as a BOP results CSV.")
    ap.add_argument("run", help="a run directory written by `bench run`")
    ap.add_argument("--out", required=True, help="CSV to write, named METHOD_DATASET-SPLIT.csv (no '_' in METHOD) as the "
                    "BOP toolkit requires; a <out>.map.csv with the id mapping is written beside it")
    args = ap.parse_args(argv)
    try:
        n = export_bop(args.run, args.out)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {n} estimates to {args.out}")
    return 0


def score_main(argv: list[str] | None = None) -> int:
    """``bench score PREDICTIONS.csv --gt RUN_DIR --method NAME --out DIR`` (or ``--dataset D --protocol P``)."""
    ap = argparse.ArgumentParser(prog="bench score",
                                 description="Score an external predictions file (BOP CSV or per-sample CSV).")
    ap.add_argument("predictions")
    ap.add_argument("--gt", help="a run directory whose ground truth (and samples) to score against")
    ap.add_argument("--dataset", help="or: a dataset config name (configs/dataset)")
    ap.add_argument("--protocol", default="gt_model", help="with --dataset: a protocol config name")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--override", action="append", default=[], help="extra Hydra override for --dataset, repeatable")
    ap.add_argument("--map", default=None, help="BOP id -> sample id CSV (default: <predictions>.map.csv if present)")
    ap.add_argument("--method", default=None, help="name of the external method (row label in tables; default: "
                    "METHOD of a METHOD_DATASET-SPLIT.csv file name)")
    ap.add_argument("--out", required=True, help="run directory to write")
    ap.add_argument("--metrics", default=",".join(DEFAULT_BOP_METRICS),
                    help="BOP datasets: comma-separated recalls, e.g. ar,ar_mssd,ar_mspd,ar_vsd,adds@0.1,add@0.1,mssd@0.2,"
                         "mspd@10,5deg5cm,10deg10cm")
    ap.add_argument("--by", default="object,category", help="BOP datasets: rows per object and/or category")
    ap.add_argument("--no-vsd", action="store_true", help="BOP datasets: skip VSD (it renders the model twice per estimate)")
    args = ap.parse_args(argv)
    try:
        if args.method is None:
            from catpose.bench.scoring.bop_eval import check_results_filename

            try:
                args.method = check_results_filename(args.predictions)[0]
            except InvalidInputError:
                raise InvalidInputError(f"pass --method NAME (the file name {Path(args.predictions).name!r} is not "
                                        "METHOD_DATASET-SPLIT.csv)") from None
        if bool(args.gt) == bool(args.dataset):
            raise InvalidInputError("pass exactly one of --gt RUN_DIR or --dataset NAME")
        gt_rows, config = gt_rows_from_run(args.gt) if args.gt else gt_rows_from_config(
            args.dataset, args.protocol, args.seed, args.override)
        preds = read_predictions(args.predictions)
        map_path = Path(args.map) if args.map else Path(str(args.predictions) + ".map.csv")
        if args.map and not map_path.is_file():
            raise InvalidInputError(f"--map {map_path} does not exist")
        mapping = read_mapping(map_path) if preds.attrs["kind"] == "bop" and map_path.is_file() else None
        rows = score_predictions(preds, gt_rows, args.method, mapping)
        config = dict(config, method={"name": args.method, "external": str(args.predictions)})
        out = write_run(args.out, rows, config, {"predictions": str(args.predictions)})
        bop_text = None
        if preds.attrs["kind"] == "bop" and _is_bop_dataset(config.get("dataset")):
            bop_text = score_bop(preds, config["dataset"], out, args.method, args.metrics.split(","),
                                 args.by.split(","), vsd=not args.no_vsd)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    n_ok = sum(r["status"] == "ok" for r in rows)
    print(f"scored {n_ok}/{len(rows)} samples with predictions; run directory {out}")
    print((out / "summary.md").read_text())
    print(_object_summary(rows, out))
    if bop_text:
        print(bop_text)
    return 0


def _object_summary(rows: Sequence[dict], out_dir: Path) -> str:
    """Per-object rows of the same statistics as ``summary.md`` (written to ``summary_objects.md``)."""
    import pandas as pd

    from catpose.bench.scoring.metrics import summarize
    from catpose.bench.run.evaluate import format_summary

    df = pd.DataFrame(list(rows))
    df["object"] = [f"{c}/{i}" for c, i in zip(df["category"], df["instance_id"])]
    text = format_summary(summarize(df, by="object"))
    (Path(out_dir) / "summary_objects.md").write_text(text + "\n")
    return text


DEFAULT_BOP_METRICS = ("ar", "ar_mssd", "ar_mspd", "ar_vsd", "adds@0.1", "5deg5cm", "10deg10cm")


def _is_bop_dataset(node: Any) -> bool:
    return isinstance(node, dict) and str(node.get("_target_", "")).endswith("datasets.bop.BOP")


def score_bop(preds, dataset_cfg: dict, out_dir: str | Path, method: str, metrics: Sequence[str],
              by: Sequence[str], vsd: bool = True) -> str:
    """BOP metrics of a BOP results CSV on the dataset of ``dataset_cfg`` (a resolved config
    dict): writes ``bop_errors.jsonl`` and ``bop_summary.md`` into ``out_dir`` and returns the
    summary (which states the target and visibility filters applied)."""
    from catpose.bench.scoring.bop_eval import ERRORS_FILE, compute_errors, format_scores, score_table, write_errors
    from catpose.bench.run.build import build_from_config

    _, ds = build_from_config(dict(dataset_cfg), "dataset")
    errs = compute_errors(preds, ds, vsd=vsd)
    header = {"method": method, "filters": list(getattr(ds, "filters", [])), "targets": len(errs),
              "matched": int(sum(r["matched"] for r in errs))}
    write_errors(errs, Path(out_dir) / ERRORS_FILE, header)
    import pandas as pd

    text = f"BOP metrics ({method}):\n" + format_scores(score_table(pd.DataFrame(errs), metrics, by), header)
    (Path(out_dir) / "bop_summary.md").write_text(text + "\n")
    return text
