"""Prediction files: a BOP results CSV or a per-sample CSV (told apart by the header), what
they must be before anything in them is scored.

- BOP results CSV ``scene_id,im_id,obj_id,score,R,t,time`` (bop_toolkit's): ``R`` is
  ``R_camera_model`` (9 row-major values), ``t`` ``t_camera_model`` in mm, ``score`` a confidence
  (higher is better), ``time`` seconds per image (-1 unknown). Named ``METHOD_DATASET-SPLIT.csv``.
- Per-sample CSV ``sample_id,R,t[,score][,time]``: ``T_template_camera`` (camera points into the
  template frame) in the object-normalised unit; ``sample_id`` a run's sample or observation id.

A text CSV with a header; BOP ids integers, a per-sample ``sample_id`` not empty; ``R`` a rotation
within :data:`ROTATION_TOL` (never projected onto the nearest one) and ``t`` finite. Every
refusal is one :class:`~catpose.errors.InvalidInputError` line naming the file, the line and the fix."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from catpose.datasets.bop_layout import ROTATION_TOL, rotation_problem
from catpose.errors import DatasetError, InvalidInputError

_INT = re.compile(r"^[+-]?\d+$")


def read_csv_text(path: Path):
    """The CSV at ``path`` as a DataFrame of strings with a ``line`` column (each row's line in the
    file, blank lines counted), or one line saying why it is not one: an empty or binary file, a
    header naming a column twice, a row with more or fewer fields than the header."""
    import csv
    import io

    import pandas as pd

    if path.is_dir():
        raise InvalidInputError(f"predictions file {path} is a folder; pass the CSV file")
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        if b"\x00" not in data:  # text in another encoding: name the byte and where it is
            line = data[: e.start].count(b"\n") + 1
            raise InvalidInputError(
                f"{path}:{line}: byte {data[e.start]:#04x} is not UTF-8 (a file saved as Latin-1?); save it as UTF-8"
            ) from None
        text = "\x00"
    if "\x00" in text:
        raise InvalidInputError(
            f"predictions file {path} is not a text CSV (binary data, e.g. a .npy); write the "
            "estimates as a BOP results CSV or a per-sample CSV (sample_id,R,t)"
        )
    reader = csv.reader(io.StringIO(text, newline=""))
    header, rows, last = None, [], 0
    try:
        for fields in reader:
            line, last = last + 1, reader.line_num
            if not fields or all(not f.strip() for f in fields):
                continue  # a blank line: skipped, but counted
            if header is None:
                header = [f.strip() for f in fields]
                twice = sorted({c for c in header if header.count(c) > 1})
                if twice:
                    raise InvalidInputError(
                        f"{path}:{line}: the header names {', '.join(twice)} twice; name each column once"
                    )
                continue
            if len(fields) != len(header):
                raise InvalidInputError(
                    f"{path}:{line}: {len(fields)} fields, but the header has {len(header)} ({','.join(header)}); "
                    "write one value per column (R and t: numbers separated by spaces, not commas)"
                )
            rows.append([*fields, line])
    except csv.Error as e:
        raise InvalidInputError(
            f"predictions file {path} is not a well-formed CSV (line {reader.line_num}: {e})"
        ) from None
    if header is None:
        raise InvalidInputError(
            f"predictions file {path} is empty; write a header (BOP: scene_id,im_id,obj_id,"
            "score,R,t,time; per sample: sample_id,R,t) and one row per estimate"
        )
    if "line" in header:
        raise InvalidInputError(f"{path}:1: a column named 'line' is not part of either format; remove it")
    df = pd.DataFrame(rows, columns=[*header, "line"], dtype=object)
    df["line"] = df["line"].astype(int)
    return df


def number_or_empty(value: Any, column: str, where: str, required: bool = False) -> float:
    """A ``score`` or ``time`` cell as a float: NaN when empty (and not ``required``), one line
    naming the cell otherwise."""
    text = str(value if value is not None else "").strip()
    if not text and not required:
        return float("nan")
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if math.isfinite(value) and (column != "time" or value >= 0 or value == -1):  # BOP: time -1 is "not measured"
        return value
    need = "a finite number" if required else "a finite number or empty"
    raise InvalidInputError(
        f"{where}: {column} must be {need}{' (seconds, or -1: not measured)' if column == 'time' else ''}, "
        f"got {text[:20]!r}"
    )


def check_ids(record: dict, kind: str, where: str) -> None:
    """Integer BOP ids, or a non-empty ``sample_id``, in one row (``where``: ``file:line``)."""
    if kind == "bop":
        for col in ("scene_id", "im_id", "obj_id"):
            value = str(record.get(col, "")).strip()
            if not _INT.match(value):
                raise InvalidInputError(f"{where}: {col} must be an integer, got {value[:20]!r}")
    elif not str(record.get("sample_id", "")).strip():
        raise InvalidInputError(
            f"{where}: sample_id is empty; give each row the sample id (or observation id) it estimates"
        )


def key_text(key: Any) -> str:
    """A prediction key as people read it: ``scene 1 image 2 object 5`` or the sample id."""
    if isinstance(key, tuple):
        return f"scene {key[0]} image {key[1]} object {key[2]}"
    return repr(key)


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
    the file. Every row is checked (the checks above: as many fields
    as the header, integer ids, a rotation, a finite translation, numeric ``score`` and ``time``);
    a bad one is refused in one line naming the file and the line.
    """
    import pandas as pd

    from catpose.geometry import invert_T, make_T

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
        T = make_T(_floats(r["R"], 9, f"{where} R").reshape(3, 3), _floats(r["t"], 3, f"{where} t"))
        why = rotation_problem(T[:3, :3])
        if why:
            raise InvalidInputError(
                f"{where}: R is not a rotation ({why}); write R as 9 row-major numbers of an "
                f"orthonormal matrix with det +1 (within {ROTATION_TOL:g})"
            )
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
