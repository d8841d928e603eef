"""Prediction files: a BOP results CSV or a per-sample CSV (told apart by the header), and an
export's id mapping.

- BOP results CSV ``scene_id,im_id,obj_id,score,R,t,time`` (bop_toolkit's): ``R`` is
  ``R_camera_model`` (9 row-major values), ``t`` ``t_camera_model`` in mm, ``score`` a confidence
  (higher is better), ``time`` seconds per image (-1 unknown). Named ``METHOD_DATASET-SPLIT.csv``.
- Per-sample CSV ``sample_id,R,t[,score][,time]``: ``T_template_camera`` (camera points into the
  template frame) in the object-normalised unit; ``sample_id`` a run's sample or observation id."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from catpose.errors import DatasetError, InvalidInputError

BOP_COLUMNS = ["scene_id", "im_id", "obj_id", "score", "R", "t", "time"]


def _floats(text: Any, n: int, where: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in str(text).replace(",", " ").split()], float)
    except ValueError:
        v = np.array([])
    if v.shape != (n,):
        raise InvalidInputError(f"{where}: expected {n} space-separated numbers, got {str(text)[:60]!r}")
    if not np.isfinite(v).all():
        raise InvalidInputError(f"{where}: has a NaN or infinite value; write {n} finite numbers")
    return v


def read_predictions(path: str | Path, inverse: bool = False):
    """Read a BOP or per-sample predictions CSV into a DataFrame with a ``T`` column.

    ``T`` is the file's (4, 4) pose as written (BOP: ``T_camera_model`` in mm; per-sample:
    ``T_template_camera``; with ``inverse``, a per-sample file holds ``T_camera_template`` and
    each pose is inverted); ``kind`` is ``"bop"`` or ``"sample"``; ``line`` is each row's line in
    the file. Every row is checked (:mod:`catpose.bench.interop.prediction_checks`: as many fields
    as the header, integer ids, a rotation, a finite translation, numeric ``score`` and ``time``);
    a bad one is refused in one line naming the file and the line.
    """
    import pandas as pd

    from catpose.bench.interop.prediction_checks import check_ids, check_pose, number_or_empty, read_csv_text
    from catpose.geometry import invert_T

    path = Path(path)
    if not path.exists():
        raise DatasetError(f"predictions file {path} does not exist")
    df = read_csv_text(path)
    cols = set(df.columns)
    if {"scene_id", "im_id", "obj_id", "R", "t"} <= cols:
        kind = "bop"
    elif {"sample_id", "R", "t"} <= cols:
        kind = "sample"
    else:
        raise InvalidInputError(
            f"{path}: header {[c for c in df.columns if c != 'line']} is neither BOP (scene_id,im_id,obj_id,score,R,t,time) "
            "nor per-sample (sample_id,R,t[,score][,time])"
        )
    if inverse and kind == "bop":
        raise InvalidInputError(
            f"--inverse: {path} is a BOP results CSV, whose poses are T_camera_model; drop --inverse"
        )
    Ts, scores, times = [], [], []
    for r in df.to_dict("records"):
        where = f"{path}:{r['line']}"
        check_ids(r, kind, where)
        T = np.eye(4)
        T[:3, :3] = _floats(r["R"], 9, f"{where} R").reshape(3, 3)
        T[:3, 3] = _floats(r["t"], 3, f"{where} t")
        check_pose(T, where)
        Ts.append(invert_T(T) if inverse else T)
        scores.append(number_or_empty(r.get("score"), "score", where, required=kind == "bop" and "score" in r))
        times.append(number_or_empty(r.get("time"), "time", where, required=kind == "bop" and "time" in r))
    df["T"] = pd.Series(Ts, index=df.index, dtype=object)
    df["score"] = pd.Series(scores, index=df.index, dtype=float)
    df["time"] = pd.Series(times, index=df.index, dtype=float)
    if kind == "bop":  # the BOP toolkit's rule: one time per image, the whole image's
        for (scene, im), group in df.groupby(["scene_id", "im_id"]):
            if group["time"].nunique(dropna=False) > 1:
                raise InvalidInputError(
                    f"{path}:{group['line'].iloc[0]}: scene {scene} image {im} has different times "
                    f"({', '.join(map(str, group['time'].unique()[:3]))}); give every estimate of an image the "
                    "image's time (BOP toolkit rule)"
                )
    df.attrs["kind"] = kind
    return df


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
