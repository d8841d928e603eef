"""A figure of a results table: accuracy at 10 and 30 degrees per method, one panel per column group.

    python tools/table_figure.py results/real/table.md --out results/real/table

reads a Markdown table as ``bench table``, ``bench report`` and ``bench suite`` write them and
draws, per group of columns (a dataset, a split part, a category), a horizontal bar per row: @30
light, @10 dark in front of it, the mean error written at the right. It writes ``<out>.png``,
``<out>.pdf`` and ``<out>.csv`` (the plotted values). ``results/make_results.sh figures`` draws
one per table the README quotes, from the committed tables alone (no run needed).

Two table shapes are read:

- suite tables (``bench suite``): a ``method`` column, then one column per part whose header
  ends ``mean / med / @10 / @30 (s)`` and whose cells read ``11.18 / 1.78 / 0.947 / 0.947 (0.27) n=38``
  (or ``mean / med / @10 / found@10 / @30 (s)``, cells ``53.00 / 2.22 / 0.711 / 1.000 / 0.711 ...``;
  found@10 is not drawn; the AR columns beside them are not read);
- metric tables (``bench table``, ``bench report``): one column per metric (``Mean° ↓``, ``@10 ↑``,
  ``@30 ↑``, ...), prefixed by a category where there are several (``Airplane @10 ↑``), rows named
  by ``Methods`` (and a ``Pipeline / Descriptor`` column, carried down over its blank cells).

Bold, underline and the failed-count notes are formatting, not values: they are dropped.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from catpose.errors import DatasetError

SUITE_HEADER = re.compile(r"^(?P<group>.*?):?\s*mean / med / @10 / (?P<found>found@10 / )?@30 \(s\)$")
#: a cell of several seeds: their mean, then `` [min-max]`` after the mean and @10 (the bars: the mean)
_SPREAD = r"(?: \[[^\]]*\])?"
SUITE_CELL = re.compile(
    rf"^(?P<mean>[-\d.]+){_SPREAD} / (?P<med>[-\d.]+) / (?P<a10>[-\d.]+){_SPREAD} / (?P<a30>[-\d.]+)"
)
#: the cell under a header with found@10: ``mean / med / @10 / found@10 (or -) / @30``
SUITE_FOUND_CELL = re.compile(
    rf"^(?P<mean>[-\d.]+){_SPREAD} / (?P<med>[-\d.]+) / (?P<a10>[-\d.]+){_SPREAD} / (?P<found>[-\d.]+|-) / (?P<a30>[-\d.]+)"
)
METRIC_HEADER = re.compile(r"^(?P<group>.*?)\s*(?P<metric>Mean°|@10|@30)\s*[↑↓]?$")


@dataclass
class Bar:
    """One row of one column group: accuracies (fractions) and the mean error (degrees)."""

    group: str
    label: str
    acc10: float
    acc30: float
    mean_deg: float
    n: int | None = None


def _plain(cell: str) -> str:
    return re.sub(r"</?u>|\*\*", "", cell).strip()


def _rows(text: str) -> tuple[str, list[str], list[list[str]]]:
    """(title, header, body rows) of the first Markdown table in ``text``."""
    lines = text.splitlines()
    start = next((k for k, ln in enumerate(lines) if ln.startswith("|")), None)
    if start is None or start + 1 >= len(lines):
        raise DatasetError("no Markdown table found")
    title = next((_plain(ln) for ln in reversed(lines[:start]) if ln.strip()), "")
    cells = []
    for ln in lines[start:]:
        if not ln.startswith("|"):
            break
        cells.append([c.strip() for c in ln.strip().strip("|").split("|")])
    return title, cells[0], [r for r in cells[2:] if len(r) == len(cells[0])]


def read_table(path: str | Path) -> tuple[str, list[Bar]]:
    """The table's title and its bars (see the module docstring); :class:`DatasetError` naming
    the file when it has neither shape."""
    path = Path(path)
    try:
        title, header, body = _rows(path.read_text())
    except (OSError, DatasetError) as e:
        raise DatasetError(f"{path}: {e}; give a table written by bench table, report or suite") from None
    bars: list[Bar] = []
    suite = {k: SUITE_HEADER.match(h) for k, h in enumerate(header)}
    if any(suite.values()):
        for row in body:
            for k, m in suite.items():
                pattern = SUITE_FOUND_CELL if m and m.group("found") else SUITE_CELL
                cell = pattern.match(_plain(row[k])) if m else None
                if cell:
                    n = re.search(r"\bn=(\d+)", row[k])
                    values = (float(cell.group(g)) for g in ("a10", "a30", "mean"))
                    bars.append(Bar(m.group("group") or "all", _plain(row[0]), *values, int(n.group(1)) if n else None))
        return title, bars
    metric = {k: METRIC_HEADER.match(h) for k, h in enumerate(header)}
    name_cols = [k for k, h in enumerate(header) if h in ("Methods", "method", "Method")]
    if not name_cols or not any(metric.values()):
        raise DatasetError(f"{path}: no method column or no Mean° / @10 / @30 columns; give a table written by bench")
    groups = list(dict.fromkeys(m.group("group") for m in metric.values() if m))
    prefix = ""
    for row in body:
        if name_cols[0] > 0 and _plain(row[0]) not in ("", "-"):
            prefix = _plain(row[0])
        elif name_cols[0] > 0 and _plain(row[0]) == "-":
            prefix = ""
        label = " ".join(x for x in (prefix, _plain(row[name_cols[0]])) if x)
        for g in groups:
            values = {m.group("metric"): _plain(row[k]) for k, m in metric.items() if m and m.group("group") == g}
            try:
                a10, a30, mean = (float(values[x]) for x in ("@10", "@30", "Mean°"))
            except (KeyError, ValueError):
                continue
            bars.append(Bar(g or "all", label, a10, a30, mean))
    return title, bars


def plot_table(path: str | Path, out_stem: str | Path, title: str | None = None, pdf: bool = True) -> list[Path]:
    """Draw the table at ``path`` (see the module docstring) into ``<out_stem>.png`` (, ``.pdf``)
    and ``<out_stem>.csv``; returns the paths."""
    from catpose.bench.report import plots

    table_title, bars = read_table(path)
    if not bars:
        raise DatasetError(f"{path}: no row with @10, @30 and a mean error to draw")
    groups = list(dict.fromkeys(b.group for b in bars))
    labels = list(dict.fromkeys(b.label for b in bars))
    plt = plots.pyplot()
    cols = min(len(groups), 3)
    rows = int(np.ceil(len(groups) / cols))
    height = 0.9 + 0.32 * len(labels)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols + 1.6, height * rows + 0.5), squeeze=False, sharey=True)
    y = np.arange(len(labels))[::-1]
    for ax, group in zip(axes.ravel(), groups):
        by_label = {b.label: b for b in bars if b.group == group}
        a30 = [by_label[lab].acc30 if lab in by_label else np.nan for lab in labels]
        a10 = [by_label[lab].acc10 if lab in by_label else np.nan for lab in labels]
        ax.barh(y, a30, height=0.7, color="C0", alpha=0.35, label="@30")
        ax.barh(y, a10, height=0.7, color="C0", label="@10")
        for yy, lab in zip(y, labels):
            if lab in by_label:
                ax.text(
                    1.02,
                    yy,
                    f"{by_label[lab].mean_deg:.1f}°",
                    va="center",
                    fontsize=8,
                    transform=ax.get_yaxis_transform(),
                )
        ax.set_xlim(0, 1)
        counts = {by_label[lab].n for lab in by_label}
        ax.set_title(group + (f" (n={counts.pop()})" if len(counts) == 1 and None not in counts else ""), fontsize=9)
        ax.set_xlabel("fraction within 10° (dark) / 30° (light)", fontsize=8)
        ax.grid(alpha=0.3, axis="x")
        ax.tick_params(labelsize=8)
    axes[0, 0].set_yticks(y, labels)
    for ax in axes.ravel()[len(groups) :]:
        ax.axis("off")
    fig.suptitle((title or table_title or Path(path).stem) + "  (right: mean error)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    columns = ["group", "label", "acc10", "acc30", "mean_deg", "n"]
    csv = plots._write_csv([vars(b) for b in bars], columns, Path(out_stem))
    return plots.save(fig, out_stem, pdf) + [csv]


def main(argv: list[str] | None = None) -> int:
    """``python tools/table_figure.py TABLE.md --out STEM [--title T] [--no-pdf]``."""
    ap = argparse.ArgumentParser(prog="table_figure", description=__doc__.split("\n\n")[0])
    ap.add_argument("table", help="a Markdown table written by bench table, bench report or bench suite")
    ap.add_argument("--out", required=True, help="output stem: STEM.png, STEM.pdf, STEM.csv")
    ap.add_argument("--title", default=None)
    ap.add_argument("--no-pdf", action="store_true")
    args = ap.parse_args(argv)
    paths = plot_table(args.table, args.out, args.title, pdf=not args.no_pdf)
    print("wrote " + ", ".join(map(str, paths)))
    return 0


if __name__ == "__main__":
    import sys

    from catpose.errors import CatposeError, command_error

    try:
        raise SystemExit(main())
    except CatposeError as e:
        print(command_error("report", e), file=sys.stderr)
        raise SystemExit(2) from None
