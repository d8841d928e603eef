"""A run on BOP-layout data scored by BOP: its rows as BOP estimates, their per-target errors,
and BOP's average recall (AR).

``bench suite`` and ``bench table`` show BOP's AR beside mean / median / @10 for runs on BOP-layout
data (real YCB-V, TYO-L, ``dataset=clutter``), computed with the code ``bench score`` uses on a
BOP results CSV (:mod:`catpose.bench.scoring.bop_eval`); a test checks the figures against
``bench export`` + ``bench score``.

AR is BOP'19's: the mean of AR_VSD (taus 5-50 mm, thresholds 0.05-0.5), AR_MSSD (0.05-0.5 of the
diameter) and AR_MSPD (5-50 px at 640 wide), each a mean recall over its thresholds; a target
without an estimate (a failed sample) is a miss at every threshold.

VSD renders the model twice per target, so a run's errors are cached outside the run (which a
table command did not create and must not write into): ``$CATPOSE_CACHE_DIR`` or
``~/.cache/catpose``, ``bop_errors/<hash>.jsonl``, the hash covering the run's rows, its
evaluation dataset config and :data:`VERSION`; a changed or resumed run gets a new entry.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from catpose.bench.run.rundir import SAMPLES_FILE

#: the BOP scores the tables show, in their order: AR and its three parts
AR_KEYS = ("ar", "ar_vsd", "ar_mssd", "ar_mspd")

#: bumped when the cached errors would change for the same run (a metric or matching fix)
VERSION = "1"

#: the dataset classes in the BOP layout (their frames carry scene, image and object ids)
BOP_TARGETS = ("catpose.datasets.bop.BOP", "catpose.datasets.clutter.Clutter")


def is_bop_layout(dataset_cfg: Any) -> bool:
    """Whether a resolved dataset config (dict) reads BOP-layout data (BOP, YCB-V, TYO-L, clutter)."""
    return isinstance(dataset_cfg, dict) and str(dataset_cfg.get("_target_", "")) in BOP_TARGETS


def evaluation_models(dataset_cfg: dict) -> dict:
    """The dataset config BOP's errors are computed with: ``models_dir: models_eval`` when the
    dataset has that folder (the BOP toolkit's evaluation models, uniformly resampled surfaces),
    whatever the run registered against; the config as it is otherwise."""
    root = dataset_cfg.get("root")
    if (
        root
        and dataset_cfg.get("models_dir", "models") == "models"
        and (Path(str(root)) / "models_eval" / "models_info.json").is_file()
    ):
        return dict(dataset_cfg, models_dir="models_eval")
    return dataset_cfg


def has_bop_ids(row: dict) -> bool:
    """Whether a row's ``info`` names its BOP ``scene_id``, ``im_id`` and ``obj_id``."""
    return all(k in (row.get("info") or {}) for k in ("scene_id", "im_id", "obj_id"))


def bop_key(info: dict) -> tuple[int, int, int]:
    """``(scene_id, im_id, obj_id)`` of a BOP sample's ``info``."""
    return int(info["scene_id"]), int(info["im_id"]), int(info["obj_id"])


def _normalisation(info: dict) -> tuple[float, np.ndarray, np.ndarray]:
    """``scale_mm``, ``centre_mm`` (3,) and ``R_object_model`` (3, 3) of a BOP sample's ``info``:
    the normalisation ``p_object = (R_object_model p_model - centre_mm) / scale_mm``."""
    scale = float(info.get("scale_mm", 1.0))
    centre = np.asarray(info.get("centre_mm", [0.0, 0.0, 0.0]), float).reshape(3)
    return scale, centre, np.asarray(info.get("R_object_model", np.eye(3)), float).reshape(3, 3)


def camera_model_pose(T_template_camera: np.ndarray, info: dict) -> np.ndarray:
    """``T_camera_model`` (4, 4), millimetres, of an estimate ``T_template_camera`` (object-normalised)
    of a BOP sample (:func:`_normalisation` of its ``info``): ``R = R_co R_object_model``,
    ``t = scale_mm t_co - R_co centre_mm`` with ``(R_co, t_co)`` the inverse of the estimate."""
    from catpose.geometry import invert_T, make_T

    scale, centre, R_om = _normalisation(info)
    T_co = invert_T(np.asarray(T_template_camera, float).reshape(4, 4))
    return make_T(T_co[:3, :3] @ R_om, scale * T_co[:3, 3] - T_co[:3, :3] @ centre)


def template_camera_pose(T_camera_model: np.ndarray, info: dict) -> np.ndarray:
    """The inverse of :func:`camera_model_pose`: ``T_template_camera`` (object-normalised) of a BOP
    estimate ``T_camera_model`` (mm)."""
    from catpose.geometry import invert_T, make_T

    scale, centre, R_om = _normalisation(info)
    T = np.asarray(T_camera_model, float).reshape(4, 4)
    R_co = T[:3, :3] @ R_om.T
    return invert_T(make_T(R_co, (T[:3, 3] + R_co @ centre) / scale))


def confidence(score: Any) -> float:
    """The BOP ``score`` of an estimate: ``exp(-max(method score, 0))`` in (0, 1], 1 without a
    score (every built-in method's score is a non-negative loss)."""
    return 1.0 if score is None or not math.isfinite(float(score)) else math.exp(-max(float(score), 0.0))


def predictions_from_units(units: Sequence[dict]):
    """The estimates of a run's scoring units (one per view) as ``bench score`` reads them from a
    BOP results CSV: a DataFrame with ``scene_id, im_id, obj_id, score, T`` (``T_camera_model``,
    mm) for every unit with an estimate; failed units are left out (their targets are misses).
    Units without BOP ids in ``info`` are left out too."""
    import pandas as pd

    rows = []
    for u in units:
        if u.get("status") == "ok" and u.get("T_est") is not None and has_bop_ids(u):
            pose = {"score": confidence(u.get("score")), "T": camera_model_pose(u["T_est"], u["info"])}
            rows.append(dict(zip(("scene_id", "im_id", "obj_id"), bop_key(u["info"]))) | pose)
    return pd.DataFrame(rows, columns=["scene_id", "im_id", "obj_id", "score", "T"])


def target_key(row: dict) -> tuple[int, int, int]:
    """``(scene_id, im_id, gt_idx)`` of a per-target error row or of a unit's ``info``."""
    return int(row["scene_id"]), int(row["im_id"]), int(row["gt_idx"])


def ar_scores(errors) -> dict[str, float]:
    """AR, AR_VSD, AR_MSSD, AR_MSPD (:data:`AR_KEYS`) of per-target errors (a DataFrame of
    :func:`~catpose.bench.scoring.bop_eval.compute_errors` rows); NaN for none."""
    from catpose.bench.scoring.bop_eval import metric_value

    return {k: metric_value(errors, k) for k in AR_KEYS}


def target_errors(run_dir: str | Path):
    """Per-target BOP errors of a run (a DataFrame: ``compute_errors``' columns plus ``sample_id``),
    on its evaluation models (:func:`evaluation_models`, as ``bench score``), or None when the run
    is not on BOP-layout data or has no sample."""
    import pandas as pd

    from catpose.bench.run.evaluate import load_protocol, recompute_row_errors
    from catpose.bench.run.run_meta import read_config
    from catpose.bench.run.rundir import latest_rows
    from catpose.disk_cache import cache_dir

    run_dir = Path(run_dir)
    dataset_cfg = read_config(run_dir).get("dataset")
    samples = run_dir / SAMPLES_FILE
    if not is_bop_layout(dataset_cfg) or not samples.is_file():
        return None
    dataset_cfg = evaluation_models(dataset_cfg)
    h = hashlib.blake2b(digest_size=12)
    h.update(VERSION.encode())
    h.update(json.dumps(dataset_cfg, sort_keys=True, default=str).encode())
    h.update(samples.read_bytes())
    cached = cache_dir() / "bop_errors" / f"{h.hexdigest()}.jsonl"
    if cached.is_file():
        try:
            return pd.DataFrame([json.loads(x) for x in cached.read_text().splitlines() if x.strip()])
        except (OSError, ValueError):
            pass  # a damaged entry is rebuilt
    rows = [recompute_row_errors(r) for r in latest_rows(samples)]
    if not rows:
        return None
    units = load_protocol(run_dir).score_units(pd.DataFrame(rows)).to_dict("records")
    errors = units_errors(units, dataset_cfg)
    from catpose import atomic

    try:
        atomic.write_text(cached, "".join(json.dumps(r) + "\n" for r in errors.to_dict("records")))
    except OSError:
        pass  # a read-only or full cache only costs the recomputation next time
    return errors


def units_errors(units: list[dict], dataset_cfg: dict):
    """Per-target errors of scoring units on the dataset of ``dataset_cfg`` (resolved, evaluation
    models chosen), restricted to the units' targets, each with its unit's ``sample_id``."""
    import pandas as pd

    from catpose.bench.run.build import build_from_config
    from catpose.bench.scoring.bop_eval import compute_errors

    _, dataset = build_from_config(dict(dataset_cfg), "dataset")
    by_target = {target_key(u["info"]): u["sample_id"] for u in units if "gt_idx" in (u.get("info") or {})}
    errors = [r for r in compute_errors(predictions_from_units(units), dataset) if target_key(r) in by_target]
    for r in errors:
        r["sample_id"] = by_target[target_key(r)]
    return pd.DataFrame(errors)
