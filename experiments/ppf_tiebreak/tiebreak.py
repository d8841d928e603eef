"""Does PPF break ours' near-ties? From stored runs of ours and PPF on the same samples (make_runs.sh),
the rule "ours' answer, but its runner-up when ours is ambiguous (runner-up margin below ``t``) and
PPF's answer lies within ``X`` degrees of the runner-up" is scored offline for several ``t`` and
``X``, per source (clutter dev scenes 0-14 and 15-39 with dirty masks, YCB-V scene 1), each seed on its own: @10
as the mean over seeds [min-max], and how many answers the rule turned right and wrong (all
seeds). A second table asks the question directly: among near-ties (margin below ``t``) where
exactly one of ours' answer and its runner-up is right (@10), how often ours' check chose the right
one, and how often PPF's answer lay within 10 degrees of the right one and of the wrong one.

Usage: python experiments/ppf_tiebreak/tiebreak.py OUT [--out results/ppf_tiebreak/dev.md]
(OUT: make_runs.sh's folder, runs in OUT/<source>/<method>-seed<k>/...)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from catpose import atomic
from catpose.api.result import AMBIGUOUS_MARGIN
from catpose.bench.run.rundir import latest_rows
from catpose.bench.scoring.metrics import FOUND_DEG, sample_errors

SOURCES = {
    "clutter": "clutter dev scenes 0-14, segmenter-like masks (dataset.mask_noise=1)",
    "ycbv1": "shared YCB-V frames, scene 1 (configs/split/ycbv.yaml, choose part)",
    "clutter15": "clutter dev scenes 15-39, segmenter-like masks (dataset.mask_noise=1)",
}
MARGINS = (0.01, 0.05, 0.1, AMBIGUOUS_MARGIN, math.inf)  # t: ours ambiguous when its margin is below
NEAR_DEG = (10.0, 20.0, 30.0)  # X: PPF's answer this close to ours' runner-up
SEEDS = (0, 1, 2)


def load(out: Path, source: str, method: str, seed: int) -> dict[str, dict]:
    """The finished rows of one run, by sample id."""
    runs = sorted((out / source / f"{method}-seed{seed}").rglob("samples.jsonl"))
    if len(runs) != 1:
        sys.exit(f"tiebreak: {out / source / f'{method}-seed{seed}'}: {len(runs)} runs, want 1; run make_runs.sh")
    return {r["sample_id"]: r for r in latest_rows(runs[0]) if r.get("status") == "ok"}


def pair_rows(ours: dict[str, dict], ppf: dict[str, dict]) -> list[dict]:
    """Per sample both methods finished: ours' and its runner-up's errors, the margin (inf: no
    runner-up), PPF's error and its distance (deg, modulo the object's symmetries) to ours' runner-up."""
    out = []
    for sid in sorted(ours.keys() & ppf.keys()):
        o, p = ours[sid], ppf[sid]
        second = (o.get("extras") or {}).get("runner_up")
        axis = None if o.get("symmetry_axis") is None else np.asarray(o["symmetry_axis"], float)
        syms = [np.asarray(S, float).reshape(4, 4) for S in o.get("symmetries") or ()]
        T_ppf = np.asarray(p["T_est"], float).reshape(4, 4)
        to_answer = sample_errors(T_ppf, np.asarray(o["T_est"], float).reshape(4, 4), axis, syms)["err_deg"]
        if isinstance(second, dict):
            T2 = np.asarray(second["T_template_camera"], float)
            to_second = sample_errors(T_ppf, T2, axis, syms)["err_deg"]
            margin, err2 = float(second["margin"]), float(o["info"]["runner_up_err_deg"])
        else:
            to_second, margin, err2 = math.inf, math.inf, math.inf
        out.append(
            {
                "obj_id": (o.get("info") or {}).get("obj_id"),
                "ours": o["err_deg"],
                "second": err2,
                "margin": margin,
                "ppf": p["err_deg"],
                "ppf_to_second": to_second,
                "ppf_to_answer": to_answer,
            }
        )
    return out


def rule_errors(rows: list[dict], t: float, x: float) -> np.ndarray:
    """The rule's error per sample: the runner-up's when margin < t and PPF lies within x deg of it."""
    return np.array([r["second"] if r["margin"] < t and r["ppf_to_second"] <= x else r["ours"] for r in rows])


def cell(values: list[float]) -> str:
    return f"{np.mean(values):.3f} [{min(values):.3f}-{max(values):.3f}]"


def fmt_t(t: float) -> str:
    return "any" if math.isinf(t) else f"{t:.4g}" + (" (AMBIGUOUS_MARGIN)" if t == AMBIGUOUS_MARGIN else "")


def source_tables(name: str, per_seed: list[list[dict]]) -> list[str]:
    n = [len(rows) for rows in per_seed]
    lines = [f"### {SOURCES[name]}", "", f"n per seed: {', '.join(map(str, n))} (seeds {SEEDS})", ""]
    lines += ["| answer | t (margin below) | X (deg) | @10 mean [min-max] | turned right | turned wrong |"]
    lines += ["|---|---|---|---|---|---|"]
    acc = lambda e: float(np.mean(np.asarray(e) <= FOUND_DEG))  # noqa: E731
    lines.append(f"| ours | | | {cell([acc([r['ours'] for r in rows]) for rows in per_seed])} | | |")
    lines.append(f"| PPF | | | {cell([acc([r['ppf'] for r in rows]) for rows in per_seed])} | | |")
    for t in MARGINS:
        for x in NEAR_DEG:
            accs, right, wrong = [], 0, 0
            for rows in per_seed:
                e = rule_errors(rows, t, x)
                base = np.array([r["ours"] for r in rows]) <= FOUND_DEG
                accs.append(acc(e))
                right += int(np.sum(~base & (e <= FOUND_DEG)))
                wrong += int(np.sum(base & (e > FOUND_DEG)))
            lines.append(f"| rule | {fmt_t(t)} | {x:.0f} | {cell(accs)} | {right} | {wrong} |")
    lines += ["", "Near-ties where exactly one of ours' answer and its runner-up is right (all seeds pooled):", ""]
    lines += ["| t (margin below) | such ties | ours' check right | PPF near the right one | PPF near the wrong one |"]
    lines += ["|---|---|---|---|---|"]
    for t in MARGINS:
        ties = [
            r
            for rows in per_seed
            for r in rows
            if r["margin"] < t and (r["ours"] <= FOUND_DEG) != (r["second"] <= FOUND_DEG)
        ]
        ours_right = sum(r["ours"] <= FOUND_DEG for r in ties)
        # the right one of the two is ours' answer or its runner-up; PPF within 10 deg of either
        dist = [(r["ppf_to_answer"], r["ppf_to_second"])[:: 1 if r["ours"] <= FOUND_DEG else -1] for r in ties]
        near_right = sum(d[0] <= FOUND_DEG for d in dist)
        near_wrong = sum(d[1] <= FOUND_DEG for d in dist)
        lines.append(f"| {fmt_t(t)} | {len(ties)} | {ours_right} | {near_right} | {near_wrong} |")
    t, x = MARGINS[0], NEAR_DEG[0]
    lines += [
        "",
        f"Per object (BOP obj_id), all seeds pooled: right (@10) of n; the rule at t = {t:g}, X = {x:.0f}:",
        "",
    ]
    lines += ["| obj_id | n | ours | PPF | rule |", "|---|---|---|---|---|"]
    pooled = [(r, e) for rows in per_seed for r, e in zip(rows, rule_errors(rows, t, x), strict=True)]
    for obj in sorted({r["obj_id"] for r, _ in pooled}, key=lambda v: -1 if v is None else v):
        mine = [(r, e) for r, e in pooled if r["obj_id"] == obj]
        right = [sum(v <= FOUND_DEG for v in col) for col in zip(*[(r["ours"], r["ppf"], e) for r, e in mine])]
        lines.append(f"| {obj} | {len(mine)} | {right[0]} | {right[1]} | {right[2]} |")
    return lines + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="make_runs.sh's run folder (outputs/ppf_tiebreak)")
    parser.add_argument("--out", dest="dest", type=Path, default=None, help="write the tables here (else print)")
    args = parser.parse_args(argv)
    lines = [
        "**Does PPF break ours' near-ties? Development parts only, seeds 0-2** (experiments/ppf_tiebreak)",
        "",
        "Rule: ours' answer, but its runner-up when ours' margin is below t and PPF's answer lies within"
        " X deg of the runner-up. turned right / wrong: answers the rule made right / wrong (all seeds).",
        "",
    ]
    for name in SOURCES:
        per_seed = [pair_rows(load(args.out, name, "ours", s), load(args.out, name, "ppf", s)) for s in SEEDS]
        lines += source_tables(name, per_seed)
    text = "\n".join(lines)
    if args.dest is None:
        print(text)
    else:
        atomic.write_text(args.dest, text)
        print(args.dest)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
