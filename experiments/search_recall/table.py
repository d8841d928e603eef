"""The development table of the search study from ``variants.py``'s outputs (README.md):

    python experiments/search_recall/table.py --out results/search_recall/dev_variants.md \
        --split clutter_objects LABEL=RUN.jsonl[:SETTINGS] ...

One row per variant: @10, found@10 and mean error over every sample, over each choose part of the
split (objects A, objects B), per object (@10 / found@10), the median CPU seconds, and how many views
went to ours' poor-fit fallback (where the run recorded it).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def rows_of(path: str) -> list[dict]:
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def poor_fit_cell(rows: list[dict], err: np.ndarray) -> str:
    """How many views ours answered by its poor-fit fallback (``depth_poor_fit``) and how many of
    them within 10 degrees; ``-`` for a run that did not record it."""
    if not rows or "poor_fit" not in rows[0]:
        return "-"
    fell = np.array([bool(r["poor_fit"]) for r in rows])
    return f"{int(fell.sum())} ({int(np.sum(fell & (err < 10)))})"


def main(argv: list[str] | None = None) -> int:
    from catpose import atomic
    from catpose.bench.real.split import load_split

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True)
    parser.add_argument("--split", default="clutter_objects")
    parser.add_argument("--title", default="Ours on the clutter dev scenes (0-99), uniform resting poses")
    parser.add_argument("runs", nargs="+", help="LABEL=RUN.jsonl, in table order")
    args = parser.parse_args(argv)
    split = load_split(args.split)
    parts = [p for p, _ in split.folds]  # the choose parts
    lines, objects = [], None
    for item in args.runs:
        label, path = item.split("=", 1)
        rows = rows_of(path)
        err = np.array([r["err_deg"] for r in rows])
        found = np.array([r["found_err_deg"] for r in rows])
        obj = np.array([int(r["obj_id"] or -1) for r in rows])
        objects = objects or sorted(set(obj.tolist()))
        wanted = {p: set(split.row_ids(p, [{"sample_id": r["sample_id"], "info": r} for r in rows])) for p in parts}

        def cell(sel: np.ndarray) -> str:
            if not sel.any():
                return "-"
            return f"{np.mean(err[sel] < 10):.3f} / {np.mean(found[sel] < 10):.3f} / {err[sel].mean():.2f}"

        cells = [label, f"{len(rows)}", cell(np.ones(len(rows), bool))]
        cells += [cell(np.array([r["sample_id"] in wanted[p] for r in rows])) for p in parts]
        cells += [f"{np.mean(err[obj == o] < 10):.2f} / {np.mean(found[obj == o] < 10):.2f}" for o in objects]
        cells.append(f"{np.median([r['cpu_s'] for r in rows]):.3f}")
        cells.append(poor_fit_cell(rows, err))
        lines.append("| " + " | ".join(cells) + " |")
    head = ["variant", "n", "all: @10 / found@10 / mean"]
    head += [f"{p} ({split.role(p)}): @10 / found / mean" for p in parts]
    head += [f"obj {o}: @10 / found" for o in objects or []] + ["CPU s (median)", "poor-fit fallback: views (right)"]
    text = "\n".join([f"**{args.title}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head), *lines, ""])
    atomic.write_text(args.out, text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
