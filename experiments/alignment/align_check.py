"""How an estimated alignment table agrees with a verified one, and whether its confidence
separates the right rows from the wrong ones (``align.py --compare VERIFIED.csv``).

The verified table is read only after the estimate is written: nothing here feeds back into
``alignment_estimate.estimate_table``.

Two tables may put the category in different frames (each is "the reference instance's frame",
and a table may be re-based), so a row agrees when its estimated rotation equals the verified one
up to one rotation common to all rows: ``R_est_i = G R_ver_i`` with ``G`` the rotation, among
``R_est_j R_ver_j^T`` over all rows, that the most rows share (ties: the first row's). A row's
confidence "ranks it right" when every agreeing row has a higher confidence than every
disagreeing one: the ROC of the confidence as a detector of agreeing rows has area 1.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from catpose.datasets.alignment import read_alignment_table
from catpose.errors import DatasetError

#: two rotations are the same alignment when no entry differs by more than this (~3 degrees)
SAME_ROTATION_TOL = 0.05


def _same(A: np.ndarray, B: np.ndarray) -> bool:
    return bool(np.abs(A - B).max() < SAME_ROTATION_TOL)


def agreement(estimated: dict[str, np.ndarray], verified: dict[str, np.ndarray]) -> tuple[np.ndarray, dict[str, bool]]:
    """The common rotation ``G`` (3, 3) and, per instance id in both tables, whether
    ``R_est = G R_ver`` (see the module docstring).

    Raises:
        DatasetError: the tables share no instance.
    """
    ids = [i for i in estimated if i in verified]
    if not ids:
        raise DatasetError("the estimated and the verified alignment tables share no instance id")
    offsets = [estimated[i] @ verified[i].T for i in ids]
    counts = [sum(_same(estimated[j], G @ verified[j]) for j in ids) for G in offsets]
    G = offsets[int(np.argmax(counts))]
    return G, {i: _same(estimated[i], G @ verified[i]) for i in ids}


def roc(confidence: list[float], right: list[bool]) -> dict:
    """ROC of ``confidence`` as a detector of right rows: ``auc`` (NaN when all rows are right
    or all wrong), ``separates`` (every right row's confidence above every wrong row's; true
    when there is no wrong row), ``min_right`` and ``max_wrong`` (NaN when there is none) and the
    curve ``fpr``, ``tpr``, ``thresholds`` (scikit-learn's ``roc_curve``; empty when undefined)."""
    c = np.asarray(confidence, float)
    ok = np.asarray(right, bool)
    min_right = float(c[ok].min()) if ok.any() else float("nan")
    max_wrong = float(c[~ok].max()) if (~ok).any() else float("nan")
    out = {"min_right": min_right, "max_wrong": max_wrong, "separates": bool((~ok).sum() == 0 or min_right > max_wrong)}
    out.update(auc=float("nan"), fpr=[], tpr=[], thresholds=[])
    if ok.any() and (~ok).any():
        from sklearn.metrics import roc_auc_score, roc_curve

        fpr, tpr, thr = roc_curve(ok.astype(int), c)
        auc = float(roc_auc_score(ok.astype(int), c))
        out.update(auc=auc, fpr=fpr.tolist(), tpr=tpr.tolist(), thresholds=[float(t) for t in thr])
    return out


def compare_tables(estimated_csv: str | Path, verified_csv: str | Path, category: str) -> dict:
    """Agreement and ROC of the ``category`` rows of ``estimated_csv`` (written by ``bench
    align``, with a ``confidence`` column) against ``verified_csv``.

    Returns ``{"n", "agree", "rows": [{instance_id, agrees, confidence, yaw_deg, flip,
    verified_yaw_deg, verified_flip}], "roc": roc(...)}``.
    """
    est = {k[1]: R for k, R in read_alignment_table(estimated_csv).items() if k[0] == category}
    ver = {k[1]: R for k, R in read_alignment_table(verified_csv).items() if k[0] == category}
    with open(estimated_csv, newline="") as fh:
        meta = {r["instance_id"]: r for r in csv.DictReader(fh) if r["category"] == category}
    G, ok = agreement(est, ver)
    rows = []
    for i, agrees in ok.items():
        conf = meta[i].get("confidence") or ""
        R_ver_in_est = G @ ver[i]
        rows.append(
            {
                "instance_id": i,
                "agrees": agrees,
                "confidence": float(conf) if conf.strip() else float("nan"),
                "yaw_deg": _yaw(est[i]),
                "flip": bool(est[i][2, 2] < 0),
                "verified_yaw_deg": _yaw(R_ver_in_est),
                "verified_flip": bool(R_ver_in_est[2, 2] < 0),
            }
        )
    return {
        "n": len(rows),
        "agree": sum(r["agrees"] for r in rows),
        "rows": rows,
        "roc": roc([r["confidence"] for r in rows], [r["agrees"] for r in rows]),
    }


def _yaw(R: np.ndarray) -> float:
    """Yaw (deg, 0..359) of the x axis's image projected on the ground plane."""
    return float(round(float(np.degrees(np.arctan2(R[1, 0], R[0, 0]))), 1) % 360.0)


def write_comparison(path: str | Path, result: dict) -> Path:
    """Per-row CSV (``instance_id, agrees, confidence, yaw_deg, flip, verified_yaw_deg,
    verified_flip``, yaws in the estimate's frame) followed by no summary: the summary is
    :func:`summary_line`."""
    from catpose import atomic

    path = Path(path)
    cols = ["instance_id", "agrees", "confidence", "yaw_deg", "flip", "verified_yaw_deg", "verified_flip"]
    with atomic.atomic_write(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in result["rows"]:
            w.writerow(
                [
                    ("true" if r[c] else "false")
                    if isinstance(r[c], bool)
                    else (f"{r[c]:.6g}" if isinstance(r[c], float) else r[c])
                    for c in cols
                ]
            )
    return path


def summary_line(result: dict) -> str:
    """``agree a/n; confidence AUC x (separates: yes/no; lowest right c, highest wrong c)``."""
    r = result["roc"]
    auc = "n/a (no wrong row)" if not np.isfinite(r["auc"]) else f"{r['auc']:.3f}"
    wrong = "none" if not np.isfinite(r["max_wrong"]) else f"{r['max_wrong']:.3f}"
    return (
        f"agree {result['agree']}/{result['n']}; confidence ROC AUC {auc}, separates right from wrong: "
        f"{'yes' if r['separates'] else 'no'} (lowest right {r['min_right']:.3f}, highest wrong {wrong})"
    )
