"""The templates protocol's default `choice`: every rule's chosen @10 and mean error on each
development table that holds a row for every rule, pooled.

    .venv/bin/python experiments/category_choice/default_choice.py \
        results/category/dev/embedded_seed1_k3.csv ... --out results/category/dev/default_choice.md

Each input is a `experiments/_lib/category_table.py --format csv` table (columns ``method``, ``choice``, ``views``,
``chosen_acc10``, ``chosen_mean``); each (table, method) row set, one per template set and method,
weighs the same. The rule: the highest mean @10 over those row sets, then the lowest mean error.
Reads the committed tables only (no run). Written by results/make_results.sh (category section).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

COLUMNS = ("method", "choice", "views", "chosen_acc10", "chosen_mean")


def pooled(tables: dict[str, pd.DataFrame]) -> tuple[pd.DataFrame, pd.DataFrame, list[str]]:
    """(per row set, pooled, rules): the per-(table, method) @10 of each rule, and each rule's mean
    @10, mean error and row sets won (highest @10, ties shared) over them; only rules every row set
    has."""
    frames = []
    for name, df in tables.items():
        missing = [c for c in COLUMNS if c not in df.columns]
        if missing:
            raise ValueError(
                f"{name}: no column(s) {missing}; pass `experiments/_lib/category_table.py --format csv` tables"
            )
        frames.append(df.assign(table=name))
    rows = pd.concat(frames, ignore_index=True)
    sets = rows.groupby(["table", "method"], sort=False)
    rules = [r for r in dict.fromkeys(rows["choice"]) if all((g["choice"] == r).any() for _, g in sets)]
    acc = rows.pivot_table(index=["table", "method"], columns="choice", values="chosen_acc10", sort=False)[rules]
    err = rows.pivot_table(index=["table", "method"], columns="choice", values="chosen_mean", sort=False)[rules]
    views = sets["views"].first()
    won = acc.eq(acc.max(axis=1), axis=0).sum()
    summary = pd.DataFrame({"mean @10": acc.mean(), "mean error": err.mean(), "row sets won": won}).loc[rules]
    return acc.assign(views=views), summary, rules


def markdown(acc: pd.DataFrame, summary: pd.DataFrame, rules: list[str], title: str) -> str:
    best = summary.sort_values(["mean @10", "mean error"], ascending=[False, True]).index[0]
    lines = [f"**{title}**", "", "| table | method | views | " + " | ".join(rules) + " |"]
    lines.append("|---|---|---:|" + "---:|" * len(rules))
    for (table, method), row in acc.iterrows():
        cells = " | ".join(f"{row[r]:.3f}" for r in rules)
        lines.append(f"| {table} | {method} | {int(row['views'])} | {cells} |")
    for stat, fmt in (("mean @10", "{:.3f}"), ("mean error", "{:.2f}"), ("row sets won", "{:d}")):
        cells = " | ".join(("**" + fmt + "**" if r == best else fmt).format(summary.at[r, stat]) for r in rules)
        lines.append(f"| all ({len(acc)} row sets) | {stat} | | {cells} |")
    lines += [
        "",
        "Chosen @10 per rule (one row per table, template set and method); the last rows pool them, each "
        "row set weighing the same (mean error: the mean of the row sets' chosen mean errors, degrees; won: "
        f"row sets where the rule has the highest @10, ties shared). In bold the rule the default takes: {best}.",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tables", nargs="+", type=Path, help="category_table.py --format csv tables")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--title", default="The templates protocol's default choice: every rule on the development tables")
    args = ap.parse_args(argv)
    tables = {}
    for path in args.tables:
        if not path.is_file():
            print(f"default_choice: no table {path}; run the scripts that write it (README)", file=sys.stderr)
            return 2
        tables[path.stem] = pd.read_csv(path)
    try:
        acc, summary, rules = pooled(tables)
    except ValueError as e:
        print(f"default_choice: {e}", file=sys.stderr)
        return 2
    tmp = args.out.with_name(args.out.name + ".tmp")
    tmp.write_text(markdown(acc, summary, rules, args.title))
    tmp.replace(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
