"""Ours' runner-up and its margin: how often the truth is ours' answer or its runner-up, and whether
a small margin marks the answers to doubt (study: README.md).

    python experiments/runner_up/runner_up.py --choose LABEL=RUN[@SPLIT:PART] [...] \
        --report LABEL=RUN[@SPLIT:PART] [...] --out-dir results/runner_up [--force]

Each ``RUN`` is a ``bench run`` directory of ours (``samples.jsonl``), made at its defaults; ``@SPLIT:PART``
keeps the rows of one part of ``configs/split/SPLIT.yaml`` (e.g. ``@ycbv:scene1``). Writes
``dev.md`` (the choice of the margin below which an answer is flagged, on the ``--choose`` runs
only) and ``report.md`` (every ``--report`` set under that margin). Ground truth enters through
the runs' errors only (``err_deg``, ``info.runner_up_err_deg``), which the runner scored.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from catpose import atomic
from catpose.bench.scoring.metrics import FOUND_DEG
from catpose.errors import CatposeError, ConfigError

#: the answers kept above the chosen margin must be right (@10) at least this often on the dev runs
TARGET_ACC = 0.99
#: margins of the dev table's rows (the operating points shown besides the chosen one)
SHOWN_MARGINS = (0.0, 0.005, 0.01, 0.02, 0.03, 0.05)


def load_rows(run: Path, part: str | None = None) -> list[dict]:
    """Per finished sample of ``run``: right (@10), the runner-up right, the margin (inf: none)."""
    from catpose.bench.run.rundir import latest_rows

    path = run / "samples.jsonl"
    if not path.is_file():
        raise ConfigError(f"{path}: no samples.jsonl; pass a bench run directory of ours")
    rows = [r for r in latest_rows(path) if r.get("status") == "ok"]  # a retried sample: its last row
    if part is not None:
        from catpose.bench.real.split import load_split

        name, _, which = part.partition(":")
        split = load_split(name)
        if which not in split.parts:
            raise ConfigError(
                f"--report ...@{part}: split {name} has no part {which!r} (it has {', '.join(split.parts)})"
            )
        keep = set(split.row_ids(which, rows))
        rows = [r for r in rows if r["sample_id"] in keep]
    out = []
    for r in rows:
        second = (r.get("extras") or {}).get("runner_up")
        err2 = (r.get("info") or {}).get("runner_up_err_deg")
        out.append(
            {
                "right": r["err_deg"] <= FOUND_DEG,
                "second_right": err2 is not None and err2 <= FOUND_DEG,
                "margin": float(second["margin"]) if isinstance(second, dict) else math.inf,
            }
        )
    if not out:
        raise ConfigError(f"{run}: no finished samples{'' if part is None else ' in ' + part}")
    return out


def choose_margin(rows: list[dict]) -> float:
    """The smallest margin above which (>=) the answers are right at least :data:`TARGET_ACC` of
    the time (among the margins the rows hold; inf when none reaches it)."""
    for t in sorted({0.0, *(r["margin"] for r in rows if math.isfinite(r["margin"]))}):
        kept = [r for r in rows if r["margin"] >= t]
        if kept and sum(r["right"] for r in kept) / len(kept) >= TARGET_ACC:
            return t
    return math.inf


def summary(rows: list[dict], margin: float) -> dict:
    """One set's figures under ``margin`` (answers below it are flagged)."""
    n = len(rows)
    wrong = [r for r in rows if not r["right"]]
    kept = [r for r in rows if r["margin"] >= margin]
    return {
        "n": n,
        "acc10": sum(r["right"] for r in rows) / n,
        "top2": sum(r["right"] or r["second_right"] for r in rows) / n,
        "wrong": len(wrong),
        "wrong_second_right": sum(r["second_right"] for r in wrong),
        "flagged": (n - len(kept)) / n,
        "kept_acc10": sum(r["right"] for r in kept) / len(kept) if kept else math.nan,
        "wrong_flagged": sum(r["margin"] < margin for r in wrong),
        "no_runner_up": sum(not math.isfinite(r["margin"]) for r in rows),
    }


HEADER = (
    "| set | n | @10 | answer or runner-up @10 | wrong | of them runner-up right | flagged (margin < {m}) "
    "| @10 of the rest | wrong flagged | no runner-up |\n|---|---|---|---|---|---|---|---|---|---|\n"
)


def line(label: str, s: dict) -> str:
    kept = "-" if math.isnan(s["kept_acc10"]) else f"{s['kept_acc10']:.3f}"  # -: every view flagged
    return (
        f"| {label} | {s['n']} | {s['acc10']:.3f} | {s['top2']:.3f} | {s['wrong']} | {s['wrong_second_right']} "
        f"| {s['flagged']:.3f} | {kept} | {s['wrong_flagged']} of {s['wrong']} | {s['no_runner_up']} |\n"
    )


def _labelled(flag: str, item: str) -> tuple[str, Path, str | None]:
    """``LABEL=RUN[@SPLIT:PART]`` as (label, run directory, ``SPLIT:PART`` or None)."""
    label, sep, spec = item.partition("=")
    if not sep or not label or not spec:
        raise ConfigError(f"{flag} {item!r}: write LABEL=RUN or LABEL=RUN@SPLIT:PART")
    run, _, part = spec.partition("@")
    return label, Path(run), part or None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--choose", nargs="+", required=True, help="LABEL=RUN[@SPLIT:PART]: the margin is chosen here")
    parser.add_argument("--report", nargs="+", required=True, help="LABEL=RUN[@SPLIT:PART]: the sets reported")
    parser.add_argument("--out-dir", type=Path, required=True, help="folder of dev.md and report.md")
    parser.add_argument("--force", action="store_true", help="replace existing dev.md / report.md")
    args = parser.parse_args(argv)
    try:
        from catpose.bench.run.overwrite import check_output, input_runs, output_errors

        outs = (args.out_dir / "dev.md", args.out_dir / "report.md")
        chosen = [_labelled("--choose", item) for item in args.choose]
        reports = [_labelled("--report", item) for item in args.report]
        for path in outs:  # before any work (docs/file-safety.md)
            check_output(path, "file", input_runs([r for _, r, _ in chosen + reports]), args.force)
        dev = [row for _, run, part in chosen for row in load_rows(run, part)]
        margin = choose_margin(dev)
        m = f"{margin:.4f}"
        dev_md = (
            f"**Ours' runner-up margin, chosen on the development runs** ({len(dev)} views: "
            + ", ".join(label for label, _, _ in chosen)
            + f")\n\nRule: the smallest margin whose answers at or above it are right (@10) at least {TARGET_ACC} of "
            f"the time. Chosen: **{m}**.\n\n" + HEADER.format(m="t")
        )
        for t in sorted({*SHOWN_MARGINS, margin} - {math.inf}):
            dev_md += line(f"dev, t = {t:.4f}" + (" (chosen)" if t == margin else ""), summary(dev, t))
        report_md = (
            f"**Ours' answer, runner-up and margin on data the margin was not chosen on** (margin {m}, "
            "chosen in `dev.md`)\n\n" + HEADER.format(m=m)
        )
        for label, run, part in reports:
            report_md += line(label, summary(load_rows(run, part), margin))
        with output_errors(args.out_dir):
            args.out_dir.mkdir(parents=True, exist_ok=True)
            atomic.write_text(outs[0], dev_md)
            atomic.write_text(outs[1], report_md)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(*outs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
