"""Predictions made elsewhere matched to a run's ground-truth rows and scored as rows of
``samples.jsonl`` (:func:`score_predictions`), and what was counted on the way (:func:`count_text`):
the scoring behind ``bench score`` (:mod:`catpose.bench.interop.score`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.bench.interop.prediction_io import key_text


def score_predictions(
    preds,
    gt_rows: Sequence[dict],
    method: str,
    stats: dict | None = None,
) -> list[dict]:
    """Per-sample rows (``samples.jsonl`` schema) for the predictions against ground-truth rows
    (``gt_rows``, with ``T_gt``; one per view is enough). A view without a prediction is a failed row
    ("no prediction"): a miss. A BOP file's ids are those of the rows' ``info`` (runs on BOP-layout
    data); several instances of one object in an image are matched greedily as bop_toolkit does (by descending score, each taking the
    unmatched instance with the smallest ``err_deg``, then ``trans_err``). Duplicates and unknown ids
    follow docs/file-safety.md (a per-sample file's last row of an id counts; a BOP (image, object)
    keeps its best-scored estimates, one per instance). ``stats`` receives :func:`count_text`'s counts."""
    from catpose.bench.run.bop_ar import bop_key, template_camera_pose
    from catpose.bench.scoring.bop_eval import by_score, nearest_rotation
    from catpose.bench.scoring.metrics import sample_errors
    from catpose.bench.scoring.rows import failed_row, scored_row
    from catpose.geometry import make_T

    kind = preds.attrs.get("kind", "sample")
    all_by_key: dict[Any, list[dict]] = {}
    for p in preds.to_dict("records"):
        key = (int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"])) if kind == "bop" else str(p["sample_id"]).strip()
        all_by_key.setdefault(key, []).append(p)

    by_key = {k: v[-1] for k, v in all_by_key.items()}

    def estimate(p: dict, k: int) -> np.ndarray:
        T = np.asarray(p["T"], float)
        T = make_T(nearest_rotation(T[:3, :3]), T[:3, 3])
        return template_camera_pose(T, gt_rows[k].get("info") or {}) if kind == "bop" else T

    def errors_of(T_est: np.ndarray, g: dict) -> dict:
        axis, symmetries = g.get("symmetry_axis"), g.get("symmetries")
        return sample_errors(
            T_est,
            np.asarray(g["T_gt"], float).reshape(4, 4),
            None if axis is None else np.asarray(axis, float),
            symmetries if isinstance(symmetries, (list, tuple)) else (),
        )

    matched: dict[int, dict] = {}
    groups: dict[Any, list[int]] = {}
    if kind == "bop":
        for k, g in enumerate(gt_rows):
            groups.setdefault(bop_key(g.get("info") or {}), []).append(k)
        for key, members in groups.items():
            cands = by_score(all_by_key.get(key, []))
            free = list(members)
            for p in cands[: len(members)]:
                errs = {k: errors_of(estimate(p, k), gt_rows[k]) for k in free}
                best = min(free, key=lambda k: (round(errs[k]["err_deg"], 9), errs[k]["trans_err"]))
                matched[best] = p
                free.remove(best)
    out = []
    for k, g in enumerate(gt_rows):
        row = {
            key: g.get(key)
            for key in (
                "sample_id",
                "group_id",
                "obs_id",
                "category",
                "instance_id",
                "template_id",
                "dataset",
                "protocol",
                "seed",
                "symmetric",
                "T_gt",
                "symmetry_axis",
                "symmetries",
                "info",
            )
        }
        row.update(method=method, extras={}, stage="")
        if kind == "bop":
            p = matched.get(k)
        else:
            p = by_key.get(str(g["sample_id"])) or by_key.get(str(g.get("obs_id")))
        if p is None:
            out.append(failed_row(row, "no prediction", stage="register", score=None, runtime_s=None))
            continue
        T_est = estimate(p, k)
        errs = errors_of(T_est, g)
        score = p.get("score")
        score = (
            None
            if score is None or not math.isfinite(float(score))
            else (-float(score) if kind == "bop" else float(score))
        )
        rt = p.get("time")
        out.append(
            scored_row(
                row,
                T_est,
                errs,
                score=score,
                runtime_s=None if rt is None or not math.isfinite(float(rt)) or float(rt) < 0 else float(rt),
            )
        )
    if stats is not None:
        stats.update(_counts(kind, all_by_key, gt_rows, groups, out))
    return out


def _counts(kind: str, all_by_key: dict, gt_rows: Sequence[dict], groups: dict, out: Sequence[dict]) -> dict:
    """The counts of :func:`score_predictions` (see :func:`count_text`)."""
    if kind == "bop":
        known = set(groups)
        wanted = {k: len(v) for k, v in groups.items()}
        ignored = sum(max(0, len(v) - wanted[k]) for k, v in all_by_key.items() if k in wanted)
        rule = "an (image, object) keeps its highest-scored estimates, one per instance"
    else:
        known = {str(g["sample_id"]) for g in gt_rows} | {str(g.get("obs_id")) for g in gt_rows}
        ignored = sum(len(v) - 1 for k, v in all_by_key.items() if k in known)
        rule = "the last row of a sample id counts"
    unknown = [k for k in all_by_key if k not in known]
    return {
        "predictions": sum(map(len, all_by_key.values())),
        "targets": len(gt_rows),
        "scored": sum(r["status"] == "ok" for r in out),
        "missing": sum(r["status"] != "ok" for r in out),
        "duplicates_ignored": ignored,
        "duplicate_rule": rule,
        "unknown_ids": len(unknown),
        "unknown_rows": sum(len(all_by_key[k]) for k in unknown),
        "unknown_examples": [key_text(k) for k in unknown[:5]],
    }


def count_text(stats: dict) -> str:
    """What a score counted, for people: scored, missing (misses), duplicates and unknown ids."""
    lines = [
        f"{stats['predictions']} prediction rows; {stats['scored']} of {stats['targets']} samples scored, "
        f"{stats['missing']} without a prediction (counted as misses: failed, 180 deg)"
    ]
    if stats["duplicates_ignored"]:
        lines.append(f"{stats['duplicates_ignored']} duplicate row(s) ignored ({stats['duplicate_rule']})")
    if stats["unknown_ids"]:
        lines.append(
            f"{stats['unknown_rows']} row(s) with {stats['unknown_ids']} id(s) that no sample has, ignored: "
            + ", ".join(stats["unknown_examples"])
            + (", ..." if stats["unknown_ids"] > 5 else "")
        )
    return "\n".join(lines)
