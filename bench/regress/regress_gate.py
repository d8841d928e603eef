"""The regression gate's rules: how one method's per-sample answers are judged against its
reference (see :mod:`catpose.bench.regress.run_suites` for the suites and the command, and
``configs/regress/default.yaml`` for how every threshold is derived).

- A sample that was ok and now fails, fails the gate.
- A *stable* sample (not flagged chaotic in the reference) that was within ``within_deg`` and now
  is not, or within ``wrong_deg`` and now is not, by a move larger than ``chaos_deg``, fails the
  gate.
- A sample that was already wrong (beyond ``wrong_deg``) gates only on its status and on crossing
  ``wrong_deg``, never on how far it moves: a wrong answer that moves is still wrong.
- Aggregates per category over the stable samples, with every error clipped at ``wrong_deg`` and
  translation errors over the samples the reference had within it, must stay within the derived
  tolerances.
- Every sample whose answer moved more than ``chaos_deg`` is reported (chaotic ones as expected).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Gate:
    """The gate's thresholds (``gate:`` in the config; the derivations are documented there)."""

    within_deg: float = 10.0
    wrong_deg: float = 30.0
    chaos_deg: float = 1.0
    perturbation: float = 1e-12
    mean_err_deg: float = 1.0
    median_err_deg: float = 1.0
    mean_trans_err: float = 0.02
    accuracy_thresholds: tuple[float, ...] = (10.0, 30.0)


def to_float(v: Any) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return float("nan")
    return f


def estimate_distance_deg(a: dict, b: dict) -> float:
    """How far apart two answers to one sample are: the symmetry-aware rotation error of one
    estimate measured against the other (degrees); 180 when exactly one of them failed, 0 when
    both did."""
    from catpose.bench.run.evaluate import row_errors

    if (a.get("T_est") is None) != (b.get("T_est") is None):
        return 180.0
    if a.get("T_est") is None:
        return 0.0
    return float(row_errors(a, a["T_est"], b["T_est"])["err_deg"])


def aggregates(
    rows: dict[str, dict], stable: set[str], gate: Gate, right: set[str] | None = None
) -> dict[str, dict[str, float]]:
    """Per-category (and ``all``) statistics over the stable samples of ``rows``, plus the
    derived accuracy tolerances: the fraction of those samples within ``chaos_deg`` of each
    accuracy threshold (they may cross it without having moved beyond noise).

    Rotation errors are clipped at ``wrong_deg`` (a failure counts as ``wrong_deg``), so a wrong
    answer that moves cannot move an aggregate; the mean translation error is taken over the
    stable samples in ``right`` (the reference's samples within ``wrong_deg``; by default those
    of ``rows`` themselves), so the set it averages does not depend on the current answers."""
    import numpy as np

    if right is None:
        right = {sid for sid, r in rows.items() if r["status"] == "ok" and r["err_deg"] <= gate.wrong_deg}
    by_cat: dict[str, list[tuple[str, dict]]] = {}
    for sid, r in rows.items():
        if sid in stable:
            by_cat.setdefault(str(r["category"]), []).append((sid, r))
            by_cat.setdefault("all", []).append((sid, r))
    out = {}
    for cat, items in sorted(by_cat.items()):
        rs = [r for _, r in items]
        err = np.array([r["err_deg"] if r["status"] == "ok" else 180.0 for r in rs], float)
        clipped = np.minimum(err, gate.wrong_deg)
        trans = np.array([r["trans_err"] if r["status"] == "ok" else np.nan for sid, r in items if sid in right], float)
        stats = {
            "n": float(len(rs)),
            "failed": float(sum(r["status"] != "ok" for r in rs)),
            "mean_err_deg": float(clipped.mean()),
            "median_err_deg": float(np.median(clipped)),
            "mean_trans_err": float(np.nanmean(trans)) if np.isfinite(trans).any() else float("nan"),
        }
        for thr in gate.accuracy_thresholds:
            stats[f"acc{thr:g}"] = float((err <= thr).mean())
            stats[f"acc{thr:g}_tolerance"] = float((np.abs(err - thr) <= gate.chaos_deg).mean())
        out[cat] = stats
    return out


@dataclass
class Finding:
    """One line of the gate's report."""

    method: str
    where: str  # a sample id or a "category/statistic"
    what: str
    fails: bool


def compare_method(method: str, ref: dict, current: dict[str, dict], gate: Gate) -> list[Finding]:
    """Judge one method's current rows against its reference entry (see the module doc)."""
    findings: list[Finding] = []
    ref_rows: dict[str, dict] = ref["samples"]
    chaotic = {sid for sid, r in ref_rows.items() if r.get("chaotic")}
    missing, extra = sorted(set(ref_rows) - set(current)), sorted(set(current) - set(ref_rows))
    for sid in missing:
        findings.append(Finding(method, sid, "sample in the reference but not run now", True))
    for sid in extra:
        findings.append(Finding(method, sid, "sample run now but not in the reference (run --update)", True))
    for sid in sorted(set(ref_rows) & set(current)):
        r, c = ref_rows[sid], current[sid]
        moved = estimate_distance_deg(r, c)
        tag = "chaotic" if sid in chaotic else "stable"
        if r["status"] == "ok" and c["status"] != "ok":
            findings.append(
                Finding(method, sid, f"failed now ({c.get('error')}); was ok at {r['err_deg']:.2f} deg", True)
            )
            continue
        if moved <= gate.chaos_deg:
            continue
        r_err = r["err_deg"] if r["status"] == "ok" else 180.0
        c_err = c["err_deg"] if c["status"] == "ok" else 180.0
        note = f"{tag}: moved {moved:.2f} deg, error {r_err:.2f} -> {c_err:.2f} deg"
        if r_err > gate.wrong_deg:  # wrong in the reference: only crossing back is news
            if c_err <= gate.wrong_deg:
                note += f" (now within {gate.wrong_deg:g} deg)"
            findings.append(Finding(method, sid, note + " (wrong in the reference: not gated)", False))
            continue
        left = [x for x in (gate.within_deg, gate.wrong_deg) if r_err <= x < c_err]
        if left:
            note += f" (left {left[0]:g} deg)"
        findings.append(Finding(method, sid, note, bool(left) and sid not in chaotic))
    stable = set(ref_rows) - chaotic
    right = {sid for sid, r in ref_rows.items() if r["status"] == "ok" and r["err_deg"] <= gate.wrong_deg}
    ref_agg = ref["aggregates"]
    cur_agg = aggregates({k: v for k, v in current.items() if k in ref_rows}, stable, gate, right)
    tolerances = {
        "n": 0.0,
        "failed": 0.0,
        "mean_err_deg": gate.mean_err_deg,
        "median_err_deg": gate.median_err_deg,
        "mean_trans_err": gate.mean_trans_err,
    }
    for cat in sorted(set(ref_agg) | set(cur_agg)):
        rs, cs = ref_agg.get(cat, {}), cur_agg.get(cat, {})
        for stat in [*tolerances, *(f"acc{t:g}" for t in gate.accuracy_thresholds)]:
            rv, cv = to_float(rs.get(stat)), to_float(cs.get(stat))
            tol = tolerances.get(stat, to_float(rs.get(f"{stat}_tolerance")))
            if math.isnan(rv) and math.isnan(cv):
                continue
            if math.isnan(rv) or math.isnan(cv) or abs(cv - rv) > tol + 1e-9:
                findings.append(Finding(method, f"{cat}/{stat}", f"{rv:.4g} -> {cv:.4g} (tolerance {tol:.3g})", True))
    return findings
