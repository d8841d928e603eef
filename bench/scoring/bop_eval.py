"""BOP evaluation of a results CSV, staged like bop_toolkit: estimates -> errors -> scores.

1. :func:`check_results_filename`: the file's name is one the BOP toolkit accepts
   (``METHOD_DATASET-SPLIT.csv``; its rows: :func:`catpose.bench.interop.prediction_io.read_predictions`).
2. :func:`compute_errors`: for every ground-truth target of a BOP dataset (the split's
   ``test_targets_bop19.json`` and ``visib_fract`` filter, applied by the dataset), the errors of
   the estimate matched to it: MSSD, MSPD, ADD, ADD-S (mm / px), rotation and translation error,
   n-degree m-cm, and VSD where depth is read. Written to ``bop_errors.jsonl``.
3. :func:`score_table`: recalls per object and per category from that file, for any choice of
   metrics and thresholds, without recomputing errors.

Matching (several instances of one object in an image): the estimates of an (image, object) are
sorted by score (ties: file order), the top ``n`` are kept (``n`` = instances to find; the others
are counted as extra estimates and ignored), and each, in that order,
takes the still unmatched gt instance with the smallest error, separately for every error type
(bop_toolkit's greedy ``match_poses``; it also requires the error to be below the threshold,
which only changes the outcome when an estimate's best instance is beyond every threshold).
A target without an estimate has infinite errors: a miss at every threshold, as in bop_toolkit.
Estimates of an (image, object) that is not a target are counted (``unknown_estimates`` in the
header of ``bop_errors.jsonl``) and ignored.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from catpose.bench.scoring import pose_metrics as pm
from catpose.errors import DatasetError, InvalidInputError

ERRORS_FILE = "bop_errors.jsonl"
DEFAULT_METRICS = ("ar", "ar_mssd", "ar_mspd", "ar_vsd", "adds@0.1", "5deg5cm", "10deg10cm")
"""The recalls ``bench score`` prints by default."""


# --------------------------------------------------------------------------------------------
# 1. The results file


def check_results_filename(path: str | Path, dataset_split: str = "ycbv-test") -> tuple[str, str, str]:
    """``(method, dataset, split)`` of a BOP results file name ``METHOD_DATASET-SPLIT[-TYPE].csv``.

    Raises :class:`InvalidInputError` with the fix when the name does not parse or ``METHOD``
    holds an underscore (bop_toolkit splits the name at the first ``_``); the example it gives ends
    in ``dataset_split``.
    """
    name = Path(path).name
    m = re.fullmatch(r"([^_]+)_([^_-]+)-([^_]+?)\.csv", name)
    if not m:
        parts = re.fullmatch(r"(.+)_([^_-]+)-([^_]+?)\.csv", name)
        example = (
            f"{parts.group(1).replace('_', '-')}_{parts.group(2)}-{parts.group(3)}.csv"
            if parts
            else f"{re.sub(r'[^A-Za-z0-9-]', '-', Path(name).stem) or 'method'}_{dataset_split}.csv"
        )
        raise InvalidInputError(
            f"results file {name!r}: the BOP toolkit needs METHOD_DATASET-SPLIT.csv with no '_' "
            f"in METHOD, e.g. {example}"
        )
    return m.group(1), m.group(2), m.group(3)


# --------------------------------------------------------------------------------------------
# 2. Errors


def nearest_rotation(R: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) nearest to ``R`` (a file's rounded values), by SVD."""
    U, _, Vt = np.linalg.svd(R)
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt


def _model_points(vertices: np.ndarray, max_points: int, seed: int) -> np.ndarray:
    """At most ``max_points`` model vertices (seeded subset), for MSSD/MSPD/ADD(-S)."""
    v = np.asarray(vertices, float)
    if max_points and len(v) > max_points:
        v = v[np.sort(np.random.default_rng(seed).choice(len(v), size=max_points, replace=False))]
    return v


def _diameter(info: dict, points: np.ndarray) -> float:
    if "diameter" in info:
        return float(info["diameter"])
    from scipy.spatial import ConvexHull  # the diameter is between hull vertices

    h = points[ConvexHull(points).vertices]
    return float(np.sqrt(((h[:, None] - h[None]) ** 2).sum(-1)).max())


def _image_width(dataset, depth_path: Path, K: np.ndarray) -> int:
    """Image width in pixels (MSPD thresholds scale with it): the depth image's header, else
    the dataset's ``camera.json``, else twice the principal point."""
    if depth_path.is_file():
        from PIL import Image

        with Image.open(depth_path) as im:
            return int(im.size[0])
    from catpose.datasets.bop_check import camera_size

    size = camera_size(dataset.root)
    return size[0] if size else int(round(2 * K[0, 2]))


def _pair_errors(R_e, t_e, R_g, t_g, K, pts, syms, depth_mm, mesh, diameter) -> dict[str, Any]:
    re_, te_ = min(pm.rt_errors(R_e, t_e, R_g, t_g, syms), key=lambda x: (x[0], x[1]))
    out = {
        "mssd": pm.mssd(R_e, t_e, R_g, t_g, pts, syms),
        "mspd": pm.mspd(R_e, t_e, R_g, t_g, K, pts, syms),
        "add": pm.add(R_e, t_e, R_g, t_g, pts),
        "adds": pm.adi(R_e, t_e, R_g, t_g, pts),
        "re_deg": re_,
        "te_mm": te_,
        "5deg5cm": float(not pm.n_deg_m_cm(R_e, t_e, R_g, t_g, 5, 5, 1.0, syms)),
        "10deg10cm": float(not pm.n_deg_m_cm(R_e, t_e, R_g, t_g, 10, 10, 1.0, syms)),
    }
    if depth_mm is not None:
        out["vsd"] = pm.vsd(R_e, t_e, R_g, t_g, depth_mm, K, mesh[0], mesh[1], diameter=diameter)
    return out


ERROR_KEYS = ("mssd", "mspd", "add", "adds", "re_deg", "te_mm", "5deg5cm", "10deg10cm", "vsd")
"""Per-target errors; ``5deg5cm``/``10deg10cm`` are 0 (correct) or 1 so that smaller is better."""


def by_score(estimates: list[dict]) -> list[dict]:
    """Estimates (rows with a ``score``) highest score first, ties in file order; NaN last."""
    return sorted(estimates, key=lambda p: -np.nan_to_num(float(p["score"]), nan=-np.inf))


def _match(errors: list[list[dict]], key: str, n_gt: int) -> list[Any]:
    """Greedy matching for one error type: ``errors[e][g]`` of estimate ``e`` (score order)
    against each of the ``n_gt`` gt instances ``g``; returns each gt's matched error (None when
    unmatched: no estimate left for it, which scores as a miss, as in bop_toolkit)."""
    taken: list[Any] = [None] * n_gt

    def scalar(v: Any) -> float:
        return float(np.mean(v)) if isinstance(v, list) else float(v)

    for row in errors:
        free = [g for g in range(n_gt) if taken[g] is None and key in row[g]]
        if free:
            g = min(free, key=lambda j: scalar(row[j][key]))
            taken[g] = row[g][key]
    return taken


def compute_errors(preds, dataset, vsd: bool = True, max_points: int = 0, seed: int = 0) -> list[dict]:
    """Per-target errors of BOP predictions against a :class:`catpose.datasets.bop.BOP` dataset.

    ``preds``: a DataFrame from :func:`catpose.bench.interop.prediction_io.read_predictions` (kind
    ``bop``: ``T`` is ``T_camera_model`` in mm). The targets are the dataset's observation ids
    (its categories, ``targets`` and ``min_visib_fract`` filters). ``vsd``: also VSD, reading
    the depth image and rendering the model twice per (estimate, instance) pair. Returns one
    dict per target with ``scene_id, im_id, obj_id, gt_idx, category, score, matched`` and the
    :data:`ERROR_KEYS` (``inf`` when unmatched; ``vsd`` a list over BOP19's taus).
    MSSD, MSPD and ADD(-S) use every model vertex, as bop_toolkit does (``max_points`` > 0: a
    seeded subset, for speed).
    """
    targets: dict[tuple[int, int, int], list[tuple]] = {}  # (scene, image, object) -> (gt_idx, category, R, t)
    for oid in dataset.observation_ids():
        category, scene, im, gt_idx = oid.split("/")
        gt = dataset._read_json(dataset.layout.scene_gt(int(scene)))[str(int(im))][int(gt_idx)]
        R, t = np.asarray(gt["cam_R_m2c"], float).reshape(3, 3), np.asarray(gt["cam_t_m2c"], float).reshape(3)
        targets.setdefault((int(scene), int(im), int(gt["obj_id"])), []).append((int(gt_idx), category, R, t))
    by_key: dict[tuple[int, int, int], list[dict]] = {}
    for p in preds.to_dict("records"):
        by_key.setdefault((int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"])), []).append(p)
    cache: dict[int, tuple] = {}
    rows: list[dict] = []
    for (scene, im, obj), gts in sorted(targets.items()):
        if obj not in cache:
            v, f = dataset.model_mm(obj)
            info = dataset.models_info(obj)
            pts = _model_points(v, max_points, seed)
            diameter = _diameter(info, v)
            syms = pm.symmetry_transforms(info.get("symmetries_discrete") or [], dataset.continuous_symmetries(obj))
            cache[obj] = (pts, syms, (v, f), diameter)
        pts, syms, mesh, diameter = cache[obj]
        cam = dataset._read_json(dataset.layout.scene_camera(scene))[str(im)]
        K = np.asarray(cam["cam_K"], float).reshape(3, 3)
        depth_path = dataset.layout.depth(scene, im)
        depth_mm = None
        if vsd and depth_path.is_file():
            from catpose.datasets.depthio import read_depth

            depth_mm = read_depth(depth_path).astype(np.float64) * float(cam.get("depth_scale", 1.0))
        width = depth_mm.shape[1] if depth_mm is not None else _image_width(dataset, depth_path, K)
        errors = [
            [
                _pair_errors(nearest_rotation(T[:3, :3]), T[:3, 3], R_g, t_g, K, pts, syms, depth_mm, mesh, diameter)
                for _, _, R_g, t_g in gts
            ]
            for T in (np.asarray(p["T"], float) for p in by_score(by_key.get((scene, im, obj), []))[: len(gts)])
        ]
        matched = {key: _match(errors, key, len(gts)) for key in ERROR_KEYS}
        for k, (g, category, _, _) in enumerate(gts):
            row = {
                "scene_id": scene,
                "im_id": im,
                "obj_id": obj,
                "gt_idx": g,
                "category": category,
                "diameter": diameter,
                "im_width": width,
                "matched": matched["mssd"][k] is not None,
                "n_estimates": len(by_key.get((scene, im, obj), [])),
            }
            for key in ERROR_KEYS:
                val = matched[key][k]
                if key == "vsd":
                    row[key] = (
                        None if depth_mm is None else (val if val is not None else [math.inf] * len(pm.BOP19_VSD_TAUS))
                    )
                else:
                    row[key] = math.inf if val is None else float(val)
            rows.append(row)
    return rows


def write_errors(rows: Sequence[dict], path: str | Path, header: dict | None = None) -> Path:
    """``bop_errors.jsonl``: a first line ``{"filters": [...], ...}`` then one row per target
    (written atomically, :mod:`catpose.atomic`)."""
    from catpose import atomic

    path = Path(path)
    with atomic.atomic_write(path) as f:
        f.write(json.dumps({"header": header or {}}) + "\n")
        for r in rows:
            f.write(json.dumps(r) + "\n")
    return path


def read_errors(path: str | Path):
    """``(DataFrame of per-target errors, header dict)`` from :func:`write_errors`'s file."""
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path} does not exist; run `bench score` on a BOP results CSV first")
    lines = path.read_text().splitlines()
    header = json.loads(lines[0]).get("header", {}) if lines else {}
    return pd.DataFrame([json.loads(x) for x in lines[1:] if x.strip()]), header


# --------------------------------------------------------------------------------------------
# 3. Scores


def parse_metric(name: str) -> tuple[str, Any]:
    """A metric name -> (column, threshold spec).

    ``ar_mssd``, ``ar_mspd``, ``ar_vsd`` (BOP19 ranges), ``ar`` (their mean), ``<err>@<f>``
    for ``err`` in mssd/add/adds (threshold ``f`` x diameter), ``mspd@<px>`` (pixels at 640
    wide), ``<n>deg<m>cm`` (``5deg5cm``, ``10deg10cm``, any n and m).
    """
    name = name.strip().lower()
    if name in ("ar", "ar_mssd", "ar_mspd", "ar_vsd"):
        return name, None
    m = re.fullmatch(r"(mssd|add|adds|mspd)@([0-9.]+)", name)
    if m:
        return m.group(1), float(m.group(2))
    m = re.fullmatch(r"([0-9.]+)deg([0-9.]+)cm", name)
    if m:
        return "ndegmcm", (float(m.group(1)), float(m.group(2)))
    raise InvalidInputError(
        f"unknown metric {name!r}; use ar, ar_mssd, ar_mspd, ar_vsd, mssd@0.1, adds@0.1, add@0.1, "
        "mspd@10 or NdegMcm (e.g. 5deg5cm)"
    )


def metric_value(df, name: str) -> float:
    """Recall of ``name`` (see :func:`parse_metric`) over the targets in ``df``."""
    col, spec = parse_metric(name)
    if len(df) == 0:
        return float("nan")
    if col == "ar_mssd":
        return float(np.mean([pm.recall(df["mssd"] / df["diameter"], th) for th in pm.BOP19_CORRECT_TH]))
    if col == "ar_mspd":
        return float(np.mean([pm.recall(df["mspd"] * 640.0 / df["im_width"], th) for th in pm.BOP19_MSPD_TH_PX]))
    if col == "ar_vsd":
        if "vsd" not in df or df["vsd"].isna().any():
            return float("nan")
        return pm.average_recall_vsd(df["vsd"].tolist())
    if col == "ar":  # BOP's AR is the mean of all three: without VSD there is no AR (not a mean of two)
        parts = [metric_value(df, m) for m in ("ar_mssd", "ar_mspd", "ar_vsd")]
        return float(np.mean(parts)) if all(np.isfinite(parts)) else float("nan")
    if col == "ndegmcm":
        n, m = spec
        stored = f"{n:g}deg{m:g}cm"
        if stored in df:  # computed jointly over the symmetric poses (0 = correct)
            return float(np.mean(df[stored].astype(float).to_numpy() == 0.0))
        R = df["re_deg"].astype(float).to_numpy()
        T = df["te_mm"].astype(float).to_numpy()
        return float(np.mean((R <= n) & (T / 10.0 <= m)))
    if col == "mspd":
        return pm.recall(df["mspd"] * 640.0 / df["im_width"], spec)
    return pm.recall(df[col] / df["diameter"], spec)


def score_table(df, metrics: Iterable[str] = DEFAULT_METRICS, by: Sequence[str] = ("object", "category")):
    """Recalls per object and/or per category, plus ``all``; a pandas DataFrame with columns
    ``group, name, n`` and one per metric."""
    import pandas as pd

    metrics = list(metrics)
    for m in metrics:
        parse_metric(m)
    groups = []
    if "object" in by:
        groups += [("object", f"obj_{int(o):06d} ({g['category'].iloc[0]})", g) for o, g in df.groupby("obj_id")]
    if "category" in by:
        groups += [("category", str(c), g) for c, g in df.groupby("category")]
    rows = [
        [kind, name, len(g), *[metric_value(g, m) for m in metrics]] for kind, name, g in [*groups, ("all", "all", df)]
    ]
    return pd.DataFrame(rows, columns=["group", "name", "n", *metrics])


def format_scores(table, header: dict | None = None) -> str:
    """Markdown of :func:`score_table`, preceded by the evaluation filters."""
    header = header or {}
    lines = [f"- {note}" for note in header.get("filters", [])]
    if header.get("targets") is not None:
        lines.append(
            f"- {header['targets']} targets, {header.get('matched', 0)} with an estimate (the others count as misses)"
        )
    if header.get("extra_estimates"):
        lines.append(
            f"- {header['extra_estimates']} estimates beyond an (image, object)'s instances ignored (the "
            "highest-scored are kept)"
        )
    if header.get("unknown_estimates"):
        lines.append(f"- {header['unknown_estimates']} estimates of an (image, object) that is no target ignored")
    no_vsd = [m for m in table.columns if m in ("ar", "ar_vsd") and table[m].isna().all()]
    if no_vsd:
        lines.append(
            f"- no VSD (scored with --no-vsd, or without depth images): {', '.join(no_vsd)} not computed (nan); "
            "ar_mssd and ar_mspd are BOP's"
        )
    body = table.to_markdown(index=False, floatfmt=".3f")
    return ("\n".join(lines) + "\n\n" if lines else "") + body
