"""What a prediction file must be before anything in it is scored.

- The file is a text CSV with a header (not empty, not binary, e.g. a ``.npy``).
- BOP ids (``scene_id``, ``im_id``, ``obj_id``) are integers; a per-sample ``sample_id`` is not
  empty.
- Each pose is a pose: ``R`` a rotation within :data:`ROTATION_TOL` (``R^T R = I`` entrywise and
  ``det R = +1``), ``t`` finite. A zero matrix, a scaled rotation or a reflection is not projected
  onto the nearest rotation and scored: the file is refused with the line number.

Every refusal is one :class:`~catpose.errors.InvalidInputError` line naming the file, the line
and the fix. How duplicates, unknown ids and missing targets are counted is
:mod:`catpose.bench.interop.score`'s (docs/file-safety.md).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from catpose.errors import InvalidInputError

ROTATION_TOL = 1e-3
"""Largest entry of ``|R^T R - I|`` and of ``|det R - 1|`` accepted for a rotation (files hold
rounded values; 9 significant digits give about 1e-9)."""

_INT = re.compile(r"^[+-]?\d+$")


def read_csv_text(path: Path):
    """The CSV at ``path`` as a DataFrame of strings, or one line saying why it is not one."""
    import pandas as pd

    if path.is_dir():
        raise InvalidInputError(f"predictions file {path} is a folder; pass the CSV file")
    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except pd.errors.EmptyDataError:
        raise InvalidInputError(
            f"predictions file {path} is empty; write a header (BOP: scene_id,im_id,obj_id,"
            "score,R,t,time; per sample: sample_id,R,t) and one row per estimate"
        ) from None
    except UnicodeDecodeError:
        raise InvalidInputError(
            f"predictions file {path} is not a text CSV (binary data, e.g. a .npy); write the "
            "estimates as a BOP results CSV or a per-sample CSV (sample_id,R,t)"
        ) from None
    except pd.errors.ParserError as e:
        raise InvalidInputError(
            f"predictions file {path} is not a well-formed CSV ({' '.join(str(e).split())[:100]})"
        ) from None


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


def rotation_problem(R: np.ndarray, tol: float = ROTATION_TOL) -> str | None:
    """Why the (3, 3) ``R`` is not a rotation within ``tol`` (None when it is one)."""
    R = np.asarray(R, float).reshape(3, 3)
    orth = float(np.abs(R.T @ R - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if orth <= tol and abs(det - 1.0) <= tol:
        return None
    return f"max |R^T R - I| = {orth:.3g}, det R = {det:.3g}"


def check_pose(T: np.ndarray, where: str) -> None:
    """``T`` (4, 4): a rotation within :data:`ROTATION_TOL` and a finite translation."""
    why = rotation_problem(T[:3, :3])
    if why:
        raise InvalidInputError(
            f"{where}: R is not a rotation ({why}); write R as 9 row-major numbers of an "
            f"orthonormal matrix with det +1 (within {ROTATION_TOL:g})"
        )
    if not np.isfinite(T[:3, 3]).all():
        raise InvalidInputError(f"{where}: t is not finite; write 3 finite numbers")


def key_text(key: Any) -> str:
    """A prediction key as people read it: ``scene 1 image 2 object 5`` or the sample id."""
    if isinstance(key, tuple):
        return f"scene {key[0]} image {key[1]} object {key[2]}"
    return repr(key)
