"""A run's rows as BOP estimates, and BOP's average recall (AR) of their per-target errors.

``bench suite`` and ``bench table`` show BOP's AR beside mean / median / @10 for runs on BOP-layout
data (real YCB-V, TYO-L, ``dataset=clutter``). They compute it with the code ``bench score``
uses on a BOP results CSV (:func:`catpose.bench.scoring.bop_eval.compute_errors`, then
:func:`~catpose.bench.scoring.bop_eval.metric_value`): this module only turns a run's scoring units
into the estimates ``bench export`` would write (:func:`predictions_from_units`, the same mapping
as :mod:`catpose.bench.interop.bop_export`), names the evaluation models
(:func:`evaluation_models`, ``bench score``'s rule) and reads AR and its parts off per-target
errors (:func:`ar_scores`). A test checks the figures against ``bench export`` + ``bench score``.

AR is BOP'19's: the mean of AR_VSD (taus 5-50 mm, thresholds 0.05-0.5), AR_MSSD (0.05-0.5 of the
diameter) and AR_MSPD (5-50 px at 640 wide), each a mean recall over its thresholds; a target
without an estimate (a failed sample) is a miss at every threshold.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

#: the BOP scores the tables show, in their order: AR and its three parts
AR_KEYS = ("ar", "ar_vsd", "ar_mssd", "ar_mspd")

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


def camera_model_pose(T_template_camera: np.ndarray, info: dict) -> np.ndarray:
    """``T_camera_model`` (4, 4), millimetres, of an estimate ``T_template_camera`` (object-normalised)
    of a BOP sample whose ``info`` has ``scale_mm``, ``centre_mm`` and ``R_object_model``
    (the normalisation ``p_object = (R_object_model p_model - centre_mm) / scale_mm``):
    ``R = R_co R_object_model``, ``t = scale_mm t_co - R_co centre_mm`` with ``(R_co, t_co)`` the
    inverse of the estimate."""
    from catpose.geometry import invert_T

    scale = float(info.get("scale_mm", info.get("mm_per_unit", 1.0)))
    centre = np.asarray(info.get("centre_mm", info.get("model_centre_mm", [0.0, 0.0, 0.0])), float).reshape(3)
    R_om = np.asarray(info.get("R_object_model", np.eye(3)), float).reshape(3, 3)
    T_co = invert_T(np.asarray(T_template_camera, float).reshape(4, 4))
    T = np.eye(4)
    T[:3, :3] = T_co[:3, :3] @ R_om
    T[:3, 3] = scale * T_co[:3, 3] - T_co[:3, :3] @ centre
    return T


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

    ids = ("scene_id", "im_id", "obj_id")
    rows = []
    for u in units:
        info = u.get("info") or {}
        if u.get("status") == "ok" and u.get("T_est") is not None and all(k in info for k in ids):
            pose = {"score": confidence(u.get("score")), "T": camera_model_pose(u["T_est"], info)}
            rows.append({k: int(info[k]) for k in ids} | pose)
    return pd.DataFrame(rows, columns=[*ids, "score", "T"])


def target_key(row: dict) -> tuple[int, int, int]:
    """``(scene_id, im_id, gt_idx)`` of a per-target error row or of a unit's ``info``."""
    return int(row["scene_id"]), int(row["im_id"]), int(row["gt_idx"])


def ar_scores(errors) -> dict[str, float]:
    """AR, AR_VSD, AR_MSSD, AR_MSPD (:data:`AR_KEYS`) of per-target errors (a DataFrame of
    :func:`~catpose.bench.scoring.bop_eval.compute_errors` rows); NaN for none."""
    from catpose.bench.scoring.bop_eval import metric_value

    return {k: metric_value(errors, k) for k in AR_KEYS}
