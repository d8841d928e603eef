"""Canonical alignment of instances within a category.

Raw ModelNet40 instances are not consistently oriented (airplanes differ by multiples of 90
degrees of yaw), so category-level ground truth needs a per-instance rotation
``R_canonical_raw`` that takes each instance's (normalised) raw frame into the category's
canonical frame. This module reads and writes that table and estimates it by Chamfer distance
against a reference instance.

The estimate is a heuristic to review, not ground truth: on the six shared ModelNet40 airplanes
(yaw4 search, 1024 outer-surface points) it put every fuselage on the reference's axis, but the
nose/tail direction came out 180 degrees off for 2 of 6 with airplane_0003 or airplane_0005 as
reference and for 4 of 6 with airplane_0001 (a high-wing plane), judged by eye from top views.
Check the table and edit ``yaw_deg`` where needed.

Table format (CSV with a header): ``category,instance_id`` and either the nine entries
``r00,r01,r02,r10,r11,r12,r20,r21,r22`` of ``R_canonical_raw`` (row-major) or ``yaw_deg``
(a rotation about +z, the up axis). Empty cells mean "not given". Instances missing from the
table are left as they are (identity).
"""

from __future__ import annotations

import csv
import itertools
from pathlib import Path

import numpy as np

from catpose.errors import DatasetError
from catpose.geometry import axis_angle_to_R

R_COLUMNS = [f"r{i}{j}" for i in range(3) for j in range(3)]


def read_alignment_table(path: str | Path) -> dict[tuple[str, str], np.ndarray]:
    """Read an alignment CSV into ``{(category, instance_id): R_canonical_raw (3, 3)}``."""
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"alignment table {path} does not exist; write one with `bench align` or unset it")
    table: dict[tuple[str, str], np.ndarray] = {}
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        cols = set(reader.fieldnames or [])
        if not {"category", "instance_id"} <= cols or not (set(R_COLUMNS) <= cols or "yaw_deg" in cols):
            raise DatasetError(f"alignment table {path} needs columns category,instance_id and "
                               f"r00..r22 or yaw_deg; it has {sorted(cols)}")
        for line, row in enumerate(reader, start=2):
            key = (row["category"].strip(), row["instance_id"].strip())
            try:
                if all((row.get(c) or "").strip() for c in R_COLUMNS):
                    R = np.array([float(row[c]) for c in R_COLUMNS]).reshape(3, 3)
                elif (row.get("yaw_deg") or "").strip():
                    R = axis_angle_to_R(np.array([0.0, 0.0, 1.0]), np.deg2rad(float(row["yaw_deg"])))
                else:
                    raise ValueError("no rotation")
            except ValueError:
                raise DatasetError(f"alignment table {path} line {line}: needs 9 numbers r00..r22 or yaw_deg") from None
            if np.abs(R @ R.T - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
                raise DatasetError(f"alignment table {path} line {line}: r00..r22 is not a rotation")
            table[key] = R
    return table


def write_alignment_table(path: str | Path, rows: list[dict]) -> None:
    """Write rows ``{category, instance_id, R (3, 3), chamfer (optional), yaw_deg (optional)}``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["category", "instance_id", *R_COLUMNS, "yaw_deg", "chamfer"])
        for r in rows:
            R = np.asarray(r["R"], float)
            yaw = r.get("yaw_deg")
            w.writerow([r["category"], r["instance_id"], *(f"{x:.9g}" for x in R.reshape(-1)),
                        "" if yaw is None else f"{yaw:.6g}",
                        "" if r.get("chamfer") is None else f"{r['chamfer']:.6g}"])


def axis_aligned_rotations() -> np.ndarray:
    """The 24 proper rotations that map coordinate axes to coordinate axes, (24, 3, 3)."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            R = np.zeros((3, 3))
            R[np.arange(3), perm] = signs
            if np.linalg.det(R) > 0:
                out.append(R)
    return np.stack(out)


def yaw_rotations(n: int) -> np.ndarray:
    """``n`` rotations about +z by multiples of 360/n degrees, (n, 3, 3)."""
    return np.stack([axis_angle_to_R(np.array([0.0, 0.0, 1.0]), 2 * np.pi * k / n) for k in range(n)])


def chamfer_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Chamfer distance: mean nearest-neighbour distance a->b plus b->a (same unit)."""
    from scipy.spatial import cKDTree

    return float(cKDTree(b).query(a)[0].mean() + cKDTree(a).query(b)[0].mean())


def estimate_alignment(reference: np.ndarray, points: np.ndarray,
                       candidates: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The candidate rotation that best aligns ``points`` to ``reference``.

    Both clouds (N, 3) are centred shapes in their normalised frames; returns
    ``R_reference_points`` (3, 3) minimising ``chamfer(points @ R.T, reference)`` over
    ``candidates`` (K, 3, 3; the 24 axis-aligned rotations by default) and that distance.
    """
    cands = axis_aligned_rotations() if candidates is None else np.asarray(candidates, float)
    costs = [chamfer_distance(points @ R.T, reference) for R in cands]
    k = int(np.argmin(costs))
    return cands[k], float(costs[k])


def rotation_candidates(kind: str) -> np.ndarray:
    """``"24"`` (axis-aligned) or ``"yawN"`` (N yaw steps about +z, e.g. ``yaw4``, ``yaw36``)."""
    if kind == "24":
        return axis_aligned_rotations()
    if kind.startswith("yaw") and kind[3:].isdigit() and int(kind[3:]) > 0:
        return yaw_rotations(int(kind[3:]))
    raise DatasetError(f"rotation search {kind!r} is not '24' or 'yaw<N>' (e.g. yaw4)")


def yaw_deg_of(R: np.ndarray) -> float | None:
    """The yaw angle in degrees when ``R`` is a pure rotation about +z, else None."""
    if abs(R[2, 2] - 1.0) > 1e-6:
        return None
    return float(np.rad2deg(np.arctan2(R[1, 0], R[0, 0])))
