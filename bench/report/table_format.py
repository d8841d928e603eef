"""A table of numbers with a direction per metric, rendered as Markdown, LaTeX (best bold, second
underlined) or CSV. Knows nothing of runs: :mod:`catpose.bench.report.tables` fills it.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Metric:
    """A statistic of :func:`catpose.bench.scoring.metrics.summarize` and how to show and rank it."""

    column: str
    md: str
    tex: str
    lower_is_better: bool
    digits: int = 3


@dataclass
class Table:
    """A table of numbers with best/second marks.

    ``rows`` and ``columns`` are tuples of labels (1 or 2 levels each); ``cells`` maps
    ``(row, column)`` to ``(value, metric key)``. Cells compete for bold/underline within
    ``(column, metric)`` when ``rank_by == "column"`` and within ``(row, metric)`` when
    ``rank_by == "row"``.
    """

    title: str
    row_header: list[str]
    rows: list[tuple[str, ...]]
    columns: list[tuple[str, ...]]
    cells: dict[tuple[tuple[str, ...], tuple[str, ...]], tuple[float, str]] = field(default_factory=dict)
    rank_by: str = "column"
    notes: list[str] = field(default_factory=list)
    #: (row, column) -> (min, max) across seeds of a cell that is their mean (shown beside it)
    spread: dict[tuple[tuple[str, ...], tuple[str, ...]], tuple[float, float]] = field(default_factory=dict)

    def ranks(self) -> dict[tuple, int]:
        """1 for the best cell(s), 2 for the second best, per ranking group (ties share a rank)."""
        groups: dict[tuple, list[tuple[tuple, float]]] = {}
        for (r, c), (v, m) in self.cells.items():
            if v is None or not math.isfinite(v) or m in ("n",):
                continue
            key = (c, m) if self.rank_by == "column" else (r, m)
            groups.setdefault(key, []).append(((r, c), v))
        out: dict[tuple, int] = {}
        for (_, m), items in groups.items():
            if len(items) < 2:
                continue
            sign = 1.0 if metric(m).lower_is_better else -1.0
            distinct = sorted({round(sign * v, 9) for _, v in items})
            for cell, v in items:
                pos = distinct.index(round(sign * v, 9))
                if pos < 2:
                    out[cell] = pos + 1
        return out

    def text(self, r: tuple, c: tuple) -> str:
        v, m = self.cells.get((r, c), (float("nan"), "mean"))
        if v is None or not math.isfinite(v):
            return "-"
        d = metric(m).digits
        lo_hi = self.spread.get((r, c))
        if lo_hi is None or not all(map(math.isfinite, lo_hi)):
            return f"{v:.{d}f}"
        return f"{v:.{d}f} [{lo_hi[0]:.{d}f}, {lo_hi[1]:.{d}f}]"


def _tex_escape(s: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("_", r"\_"), ("#", r"\#")):
        s = s.replace(a, b)
    return s


def _tex_label(label: str) -> str:
    """A metric's LaTeX header (``METRICS[...].tex``) or the escaped label."""
    for m in [*METRICS.values(), *_DYNAMIC.values()]:
        if label == m.md:
            return m.tex
    return _tex_escape(label)


def _body(table: Table, best: str, second: str, label=lambda x: x) -> list[tuple[tuple, list[str]]]:
    """Each row and its cells: its labels (by ``label``), each left empty under the same one in the
    row above (the last always shown), then its values, the best of its ranking group formatted by
    ``best``, the second by ``second`` (``str.format`` patterns with one ``{}``)."""
    ranks, out, prev = table.ranks(), [], ()
    for r in table.rows:
        cells = [label(x) if (k == len(r) - 1 or prev[: k + 1] != r[: k + 1]) else "" for k, x in enumerate(r)]
        for c in table.columns:
            t, rank = table.text(r, c), ranks.get((r, c))
            cells.append(best.format(t) if rank == 1 else second.format(t) if rank == 2 else t)
        out.append((r, cells))
        prev = r
    return out


def to_markdown(table: Table) -> str:
    """GitHub Markdown: best in **bold**, second <u>underlined</u>."""
    head = table.row_header + [" ".join(x for x in c if x) for c in table.columns]
    lines = [f"**{table.title}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(cells) + " |" for _, cells in _body(table, "**{}**", "<u>{}</u>")]
    lines += [""] + [f"{n}" for n in table.notes]
    return "\n".join(lines).rstrip() + "\n"


def to_latex(table: Table) -> str:
    """A booktabs ``tabular``: best in ``\\textbf``, second in ``\\underline``."""
    n_lead = len(table.row_header)
    two_level = any(len(c) > 1 for c in table.columns)
    spec = "l" * n_lead + " " + " ".join("c" for _ in table.columns)
    out = [
        r"\begin{table}[t]",
        r"\centering",
        rf"\caption{{{_tex_escape(table.title)}}}",
        r"\resizebox{\columnwidth}{!}{%",
        rf"\begin{{tabular}}{{{spec}}}",
        r"\toprule",
    ]
    if two_level:
        spans = [(name, len(list(run))) for name, run in itertools.groupby(c[0] for c in table.columns)]
        top = [""] * n_lead + [rf"\multicolumn{{{n}}}{{c}}{{{_tex_escape(name)}}}" for name, n in spans]
        out.append(" & ".join(top) + r" \\")
    bottom = [rf"\textbf{{{_tex_escape(h)}}}" for h in table.row_header] + [_tex_label(c[-1]) for c in table.columns]
    out += [" & ".join(bottom) + r" \\", r"\midrule"]
    prev: tuple = ()
    for r, cells in _body(table, r"\textbf{{{}}}", r"\underline{{{}}}", _tex_label):
        if prev and n_lead > 1 and prev[0] != r[0]:
            out.append(r"\midrule")
        out.append(" & ".join(cells) + r" \\")
        prev = r
    out += [r"\bottomrule", r"\end{tabular}%", "}", r"\end{table}"]
    return "\n".join(out) + "\n"


def to_csv(table: Table) -> str:
    """Plain CSV, one row per table row, full precision, no marks (empty for missing); a cell
    pooling seeds is their mean (its min and max are in the Markdown and LaTeX tables)."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(table.row_header + ["/".join(x for x in c if x) for c in table.columns])
    for r in table.rows:
        vals = []
        for c in table.columns:
            v = table.cells.get((r, c), (float("nan"), ""))[0]
            vals.append("" if v is None or not math.isfinite(v) else repr(float(v)))
        w.writerow(list(r) + vals)
    return buf.getvalue()


def prune(table: Table) -> Table:
    """Drop rows, then columns, with no finite value (runs without the shown categories)."""

    def finite(r, c) -> bool:
        v = table.cells.get((r, c), (float("nan"), ""))[0]
        return v is not None and math.isfinite(v)

    rows = [r for r in table.rows if any(finite(r, c) for c in table.columns)]
    cols = [c for c in table.columns if any(finite(r, c) for r in rows)]
    if rows and cols:
        dropped = [r[-1] if len(r) == 1 else " ".join(r) for r in table.rows if r not in rows]
        table.rows, table.columns = rows, cols
        if dropped:
            table.notes.append(f"Without results for these categories: {', '.join(dropped)}.")
    return table


METRICS: dict[str, Metric] = {
    "mean": Metric("mean_err_deg", "Mean° ↓", r"Mean$^{\circ}\downarrow$", True),
    "median": Metric("median_err_deg", "Med.° ↓", r"Med.$^{\circ}\downarrow$", True),
    "acc10": Metric("acc10", "@10 ↑", r"$@10\uparrow$", False),
    "acc30": Metric("acc30", "@30 ↑", r"$@30\uparrow$", False),
    "trans": Metric("mean_trans_err", "L_T ↓", r"$\mathcal{L}_T\downarrow$", True),
    "runtime": Metric("median_runtime_s", "time [s] ↓", r"time [s]$\downarrow$", True, 2),
    "n": Metric("n", "n", "n", False, 0),
    "failed": Metric("failed", "failed ↓", r"failed$\downarrow$", True, 0),
    # BOP'19 average recall and its parts (runs on BOP-layout data: catpose.bench.run.bop_ar)
    "ar": Metric("ar", "AR ↑", r"AR$\uparrow$", False),
    "ar_vsd": Metric("ar_vsd", "AR_VSD ↑", r"AR$_{VSD}\uparrow$", False),
    "ar_mssd": Metric("ar_mssd", "AR_MSSD ↑", r"AR$_{MSSD}\uparrow$", False),
    "ar_mspd": Metric("ar_mspd", "AR_MSPD ↑", r"AR$_{MSPD}\uparrow$", False),
}

#: metrics made from a key on first use (:func:`metric`): ``acc5``, ``auc30``, ``5deg5cm``, ...
_DYNAMIC: dict[str, Metric] = {}


def metric(key: str) -> Metric:
    """A metric of :data:`METRICS`, or one of the threshold keys of
    :mod:`catpose.bench.scoring.curves` (``acc<X>``, ``auc<X>``, ``<n>deg<m>cm``; higher is
    better). An unknown key is a one-line :class:`catpose.errors.ConfigError`."""
    if key in METRICS:
        return METRICS[key]
    if key not in _DYNAMIC:
        from catpose.bench.scoring.curves import KEY_HELP, parse_key
        from catpose.errors import ConfigError

        parsed = parse_key(key)
        if parsed is None:
            raise ConfigError(f"unknown metric {key!r}; use some of {', '.join(METRICS)} or {KEY_HELP}")
        kind, params = parsed
        if kind == "acc":
            md, tex = f"@{params[0]:g} ↑", rf"$@{params[0]:g}\uparrow$"
        elif kind == "auc":
            md, tex = f"AUC@{params[0]:g} ↑", rf"AUC$@{params[0]:g}\uparrow$"
        else:
            md, tex = f"{params[0]:g}°{params[1]:g}cm ↑", rf"${params[0]:g}^{{\circ}}{params[1]:g}$cm$\uparrow$"
        _DYNAMIC[key] = Metric(key, md, tex, False)
    return _DYNAMIC[key]
