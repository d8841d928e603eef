"""Accuracy at any threshold, n-degree m-cm and the area under the accuracy curve: statistics of
per-unit errors beside :func:`catpose.bench.scoring.metrics.summarize`'s fixed @10 / @30
(``bench table --metrics``; docs/evaluation.md).

- ``acc<X>``: fraction of units whose ``err_deg`` is at most ``X`` degrees.
- ``<n>deg<m>cm``: error at most ``n`` degrees and translation error of the object's origin in
  the camera frame, ``|| (-R_est^T t_est) - (-R_gt^T t_gt) ||`` of the ``T_template_camera``
  poses (NOCS's convention), at most ``m`` cm, with the row's ``info["scale_mm"]`` (mm per object
  unit); NaN (a table's ``-``) where a unit has no scale. Rows without both poses (relative
  pairs) use their ``trans_err``.
- ``auc<X>``: the area under the accuracy curve from 0 to ``X`` degrees over ``X``, exactly:
  ``mean(max(0, 1 - e / X))``.

Failed units count as :data:`FAILED_ERROR_DEG` and as wrong in every statistic."""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.bench.scoring.metrics import FAILED_ERROR_DEG, accuracy
from catpose.errors import ConfigError

_NUMBER = r"(\d+(?:\.\d+)?)"
KEY_HELP = "acc<X> (degrees), auc<X> (area under the accuracy curve up to X degrees), <n>deg<m>cm"


def parse_key(key: str) -> tuple[str, tuple[float, ...]] | None:
    """``("acc", (X,))``, ``("auc", (X,))``, ``("ndegmcm", (n, m))`` of a metric key, or None
    when ``key`` is none of those forms."""
    m = re.fullmatch(rf"(acc|auc){_NUMBER}", key)
    if m:
        x = float(m.group(2))
        return (m.group(1), (x,)) if x > 0 else None
    m = re.fullmatch(rf"{_NUMBER}deg{_NUMBER}cm", key)
    if m:
        return "ndegmcm", (float(m.group(1)), float(m.group(2)))
    return None


def auc(errors_deg: Sequence[float], max_deg: float) -> float:
    """Area under the accuracy curve on [0, ``max_deg``] degrees over ``max_deg`` (see the
    module docstring); NaN for no errors."""
    e = np.asarray(errors_deg, float)
    if e.size == 0:
        return float("nan")
    return float(np.clip(1.0 - e / float(max_deg), 0.0, 1.0).mean())


def scored_errors(units) -> np.ndarray:
    """(n,) errors (degrees) of scoring units, a failed unit (or one without an error) as
    :data:`FAILED_ERROR_DEG`."""
    import pandas as pd

    err = (
        pd.to_numeric(units["err_deg"], errors="coerce").to_numpy(float)
        if "err_deg" in units
        else np.full(len(units), np.nan)
    )
    failed = (units["status"] != "ok").to_numpy() if "status" in units else np.zeros(len(units), bool)
    return np.where(failed | np.isnan(err), FAILED_ERROR_DEG, err)


def _origin_error(T_est: Any, T_gt: Any, trans_err: Any) -> float:
    """Object-origin distance in the camera frame (object units), or ``trans_err`` without poses."""
    try:
        Te, Tg = np.asarray(T_est, float).reshape(4, 4), np.asarray(T_gt, float).reshape(4, 4)
    except (TypeError, ValueError):
        return float("nan") if trans_err is None else float(trans_err)
    oe, og = -Te[:3, :3].T @ Te[:3, 3], -Tg[:3, :3].T @ Tg[:3, 3]
    return float(np.sqrt(((oe - og) ** 2).sum()))


def translation_cm(units) -> np.ndarray:
    """Per unit, the object-origin translation error in centimetres (NaN without a metric scale
    or an estimate)."""
    n = len(units)
    out = np.full(n, np.nan)
    column = lambda name, default=None: units[name].tolist() if name in units else [default] * n  # noqa: E731
    infos, T_est, T_gt, trans = column("info"), column("T_est"), column("T_gt"), column("trans_err")
    status = column("status", "ok")
    for k in range(n):
        info = infos[k] if isinstance(infos[k], dict) else {}
        scale = info.get("scale_mm")
        if scale is None or status[k] != "ok":
            continue
        out[k] = _origin_error(T_est[k], T_gt[k], trans[k]) * float(scale) / 10.0
    return out


def statistic(units, key: str) -> float:
    """The statistic ``key`` (see the module docstring) over the scoring units ``units`` (a
    DataFrame with ``status``, ``err_deg`` and, for n-degree m-cm, ``info``, ``T_est``,
    ``T_gt``, ``trans_err``). NaN for no units, or for n-degree m-cm when a unit has no metric
    scale."""
    parsed = parse_key(key)
    if parsed is None:
        raise ConfigError(f"unknown threshold metric {key!r}; use {KEY_HELP}")
    if len(units) == 0:
        return float("nan")
    kind, params = parsed
    err = scored_errors(units)
    if kind == "acc":
        return accuracy(err, params[0])
    if kind == "auc":
        return auc(err, params[0])
    if "info" not in units or not all(isinstance(i, dict) and i.get("scale_mm") is not None for i in units["info"]):
        return float("nan")  # a unit without a metric scale
    cm = translation_cm(units)
    ok = (err <= params[0]) & np.nan_to_num(cm <= params[1], nan=False).astype(bool)
    return float(ok.mean())
