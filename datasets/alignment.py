"""Alignment tables: a per-instance rotation ``R_canonical_raw`` that takes an instance's
(normalised) raw frame into its category's canonical frame.

Raw ModelNet40 instances are not consistently oriented (airplanes differ by multiples of 90
degrees of yaw), so category-level ground truth on the raw release needs such a table
(``dataset.alignment_table``). The verified tables of the shared shapes are in
``results/alignment/``; ``experiments/alignment/align.py`` estimates one and draws a contact sheet
to check its rows by eye.

Table format (CSV with a header): ``category,instance_id`` and either the nine entries
``r00,r01,r02,r10,r11,r12,r20,r21,r22`` of ``R_canonical_raw`` (row-major) or ``yaw_deg``
(a rotation about +z, the up axis) with ``flip`` (``true``: the up axis turned over). Empty cells
mean "not given". A dataset refuses a table that misses an instance it uses
(``check_alignment_covers`` of the ModelNet40 loaders), has two rows for one instance, or holds a number that is not
finite. Other columns (``chamfer``, ``confidence``, ``verified``, ``note``) are ignored.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from catpose import libm
from catpose.errors import DatasetError
from catpose.geometry import axis_angle_to_R, dot3, matmul3

R_COLUMNS = [f"r{i}{j}" for i in range(3) for j in range(3)]
FLIP = np.diag([1.0, -1.0, -1.0])  # 180 deg about +x: the up axis turned over


def read_alignment_table(path: str | Path | list) -> dict[tuple[str, str], np.ndarray]:
    """Read an alignment CSV into ``{(category, instance_id): R_canonical_raw (3, 3)}``.

    ``path`` may also be a list of CSVs, or their paths joined by commas (e.g. one verified table
    per category: ``dataset.alignment_table=a.csv,b.csv``), read in order; a later file's row
    replaces an earlier one's for the same instance.

    Every row is checked: finite numbers (a ``yaw_deg`` of ``nan`` or ``inf`` is refused here,
    naming the line, not later as a degenerate shape), a rotation, and one row per instance within
    a file (a second row of an instance is refused with both lines). Whether the table covers the
    instances a dataset uses is the loader's check (``check_alignment_covers``)."""
    if isinstance(path, str) and "," in path and not Path(path).is_file():
        path = [p.strip() for p in path.split(",") if p.strip()]
    if not isinstance(path, (str, Path)):
        merged: dict[tuple[str, str], np.ndarray] = {}
        for p in path:
            merged.update(read_alignment_table(p))
        return merged
    path = Path(path)
    if not path.is_file():
        raise DatasetError(
            f"alignment table {path} does not exist; write one with experiments/alignment/align.py or unset it"
        )
    table: dict[tuple[str, str], np.ndarray] = {}
    lines: dict[tuple[str, str], int] = {}
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        cols = set(reader.fieldnames or [])
        if not {"category", "instance_id"} <= cols or not (set(R_COLUMNS) <= cols or "yaw_deg" in cols):
            raise DatasetError(
                f"alignment table {path} needs columns category,instance_id and "
                f"r00..r22 or yaw_deg; it has {sorted(cols)}"
            )
        for line, row in enumerate(reader, start=2):
            key = ((row["category"] or "").strip(), (row["instance_id"] or "").strip())
            if not all(key):
                raise DatasetError(f"alignment table {path} line {line}: category and instance_id must not be empty")
            if key in lines:
                raise DatasetError(
                    f"alignment table {path} lines {lines[key]} and {line}: two rows for {key[0]}/{key[1]}; "
                    "keep one row per instance"
                )
            lines[key] = line
            table[key] = _row_rotation(row, f"alignment table {path} line {line}")
    return table


def _cell(row: dict, column: str) -> str:
    return (row.get(column) or "").strip()


def _row_rotation(row: dict, where: str) -> np.ndarray:
    """``R_canonical_raw`` (3, 3) of one table row, or one :class:`DatasetError` line naming ``where``.

    ``r00..r22`` (all nine) or ``yaw_deg`` give it, with ``flip`` (``true``: the up axis turned
    over, ``R = R_z(yaw) diag(1, -1, -1)``). Where a row has both, they must agree: ``align.py``
    writes both, and a person who fixes a row by editing ``yaw_deg`` (or ``flip``) must clear or
    edit ``r00..r22`` too, so that neither the edit nor the old matrix is silently ignored."""
    given = [c for c in R_COLUMNS if _cell(row, c)]
    if given and len(given) != 9:
        raise DatasetError(f"{where}: has {len(given)} of r00..r22; give all nine, or clear them and give yaw_deg")
    yaw_text, flip_text = _cell(row, "yaw_deg"), _cell(row, "flip").lower()
    if not given and not yaw_text:
        raise DatasetError(f"{where}: needs 9 numbers r00..r22 or yaw_deg")
    if flip_text not in ("", "true", "false"):
        raise DatasetError(f"{where}: flip = {_cell(row, 'flip')!r} is not true or false")
    values = {}
    for c in (*given, *(["yaw_deg"] if yaw_text else [])):
        try:
            values[c] = float(_cell(row, c))
        except ValueError:
            raise DatasetError(
                f"{where}: {c} = {_cell(row, c)[:20]!r} is not a number; needs 9 numbers r00..r22 or yaw_deg"
            ) from None
        if not np.isfinite(values[c]):  # before any use: a nan yaw is this line's fault, not the mesh's
            raise DatasetError(
                f"{where}: {c} = {_cell(row, c)} is not a finite number; write finite numbers (yaw_deg in degrees, e.g. 90)"
            )
    from_yaw = None
    if yaw_text:
        from_yaw = axis_angle_to_R(np.array([0.0, 0.0, 1.0]), np.deg2rad(values["yaw_deg"]))
        if flip_text == "true":
            from_yaw = matmul3(from_yaw, FLIP)
    if not given:
        return from_yaw
    R = np.array([values[c] for c in R_COLUMNS]).reshape(3, 3)
    if np.abs(matmul3(R, R.T) - np.eye(3)).max() > 1e-3 or dot3(np.cross(R[0], R[1]), R[2]) < 0:
        raise DatasetError(f"{where}: r00..r22 is not a rotation")
    if from_yaw is not None and np.abs(R - from_yaw).max() > 1e-3:
        yaw = yaw_deg_of(R)
        matrix = f"a yaw of {yaw:g} deg" if yaw is not None else "not a yaw about +z"
        raise DatasetError(
            f"{where}: yaw_deg = {yaw_text} (flip {flip_text or 'false'}) and r00..r22 ({matrix}) disagree; "
            "edit one and clear the other: keep yaw_deg (and flip) and empty r00..r22, or write r00..r22 "
            "and empty yaw_deg"
        )
    return R


def yaw_deg_of(R: np.ndarray) -> float | None:
    """The yaw angle in degrees when ``R`` is a pure rotation about +z, else None."""
    if abs(R[2, 2] - 1.0) > 1e-6:
        return None
    return float(np.rad2deg(libm.arctan2(R[1, 0], R[0, 0])))
