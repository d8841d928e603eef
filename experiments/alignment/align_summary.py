"""The alignment estimates against the verified tables, one Markdown row per comparison that
``align.py --compare VERIFIED.csv`` wrote (``<estimate>_vs_verified.csv``): agreement, the ROC
AUC of the confidence as a detector of right rows, whether it separates them, the wrong rows::

    python experiments/alignment/align_summary.py NAME=<estimate>_vs_verified.csv ... --out summary.md
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from align_check import roc  # noqa: E402  (the sibling script)


def read_comparison(path: str | Path) -> dict:
    """A comparison CSV written by :func:`write_comparison`, back as :func:`compare_tables`' dict."""
    with open(path, newline="") as fh:
        rows = [
            {"instance_id": r["instance_id"], "agrees": r["agrees"] == "true", "confidence": float(r["confidence"])}
            for r in csv.DictReader(fh)
        ]
    return {
        "n": len(rows),
        "agree": sum(r["agrees"] for r in rows),
        "rows": rows,
        "roc": roc([r["confidence"] for r in rows], [r["agrees"] for r in rows]),
    }


def main(argv: list[str] | None = None) -> int:
    """``python experiments/alignment/align_summary.py NAME=COMPARISON_CSV ... [--out FILE]``: one
    Markdown row per comparison (agreement, ROC AUC, whether the confidence separates, wrong rows)."""
    import argparse

    ap = argparse.ArgumentParser(prog="python experiments/alignment/align_summary.py", description=main.__doc__)
    ap.add_argument("items", nargs="+", help="NAME=<estimate>_vs_verified.csv")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    lines = [
        "| set | agree | confidence ROC AUC | separates | lowest right | highest wrong | wrong rows |",
        "|---|---:|---:|---|---:|---:|---|",
    ]
    for item in args.items:
        name, _, path = item.partition("=")
        if not path or not Path(path).is_file():
            print(f"error: {item!r} is not NAME=<existing comparison csv>", file=sys.stderr)
            return 2
        r = read_comparison(path)
        roc_ = r["roc"]
        auc = "n/a" if not np.isfinite(roc_["auc"]) else f"{roc_['auc']:.3f}"
        wrong = ", ".join(x["instance_id"] for x in r["rows"] if not x["agrees"]) or "-"
        hw = "-" if not np.isfinite(roc_["max_wrong"]) else f"{roc_['max_wrong']:.3f}"
        lines.append(
            f"| {name} | {r['agree']}/{r['n']} | {auc} | {'yes' if roc_['separates'] else 'no'} | "
            f"{roc_['min_right']:.3f} | {hw} | {wrong} |"
        )
    text = "\n".join(lines) + "\n"
    if args.out:
        Path(args.out).write_text(text)
    print(text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
