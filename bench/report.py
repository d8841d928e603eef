"""``bench report``: tables and figures of run directories in one folder a person can open.

    bench report outputs/synthetic-gt_model --out report/ [--layout optimizer] [--qualitative 2]

writes ``index.md`` and ``index.html`` (linking everything), ``tables/<layout>.{md,tex,csv}``,
``figures/{error_cdf,accuracy,runtime}.{png,pdf}`` and, with ``--qualitative N``, ``N`` pictures
per run (the sample with the median error and the worst ones) rebuilt from each run's config.
Everything is made from the run directories' files.
"""

from __future__ import annotations

import argparse
import html
import sys
from pathlib import Path
from typing import Sequence

from catpose.errors import CatposeError


def qualitative_picks(units, n: int) -> list[str]:
    """Sample ids to picture: the unit with the median error, then the worst ones (ok samples first)."""
    import numpy as np

    if n <= 0 or len(units) == 0 or "T_est" not in units:
        return []
    ok = units[(units["status"] == "ok") & units["T_est"].notna()].sort_values("err_deg", kind="stable")
    if len(ok) == 0:
        return []
    picks = [ok.iloc[len(ok) // 2]["sample_id"]]
    for sid in ok.iloc[::-1]["sample_id"]:
        if len(picks) >= n:
            break
        if sid not in picks:
            picks.append(sid)
    return [str(s) for s in picks[: int(np.clip(n, 0, len(ok)))]]


def build_report(run_dirs: Sequence[str | Path], out: str | Path, layouts: Sequence[str] = ("generic",),
                 qualitative: int = 0, labels: dict[str, str] | None = None) -> Path:
    """Write the report folder; returns the path of ``index.md``."""
    from catpose.bench import plots, tables

    out = Path(out)
    (out / "tables").mkdir(parents=True, exist_ok=True)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    runs = [tables.load_run(p) for p in tables.find_run_dirs(run_dirs)]
    labels = labels or {}

    def label_of(run: tables.Run) -> str:
        base = tables.user_label(run, labels) or tables.method_label(run)
        return base if len({r.method for r in runs}) == len(runs) else f"{base} ({run.protocol}, {run.path.name[-8:]})"

    md = ["# catpose report", "", "Runs:", ""]
    for run in runs:
        dataset = run.config.get("dataset")
        dataset = dataset.get("name", "?") if isinstance(dataset, dict) else run.info.get("dataset", "?")
        md.append(f"- **{label_of(run)}**: `{run.path}` ({run.method} on {dataset}, protocol {run.protocol}, "
                  f"{len(run.samples)} samples)")
    md += ["", "## Tables", ""]
    for layout in layouts:
        table = tables.build_table(runs, layout, labels=labels)
        for fmt, ext in (("md", "md"), ("latex", "tex"), ("csv", "csv")):
            (out / "tables" / f"{layout}.{ext}").write_text(tables.RENDERERS[fmt](table))
        md += [tables.to_markdown(table), f"Files: [md](tables/{layout}.md), [LaTeX](tables/{layout}.tex), "
               f"[CSV](tables/{layout}.csv)", ""]

    run_units = [tables.scored_units(r) for r in runs]  # in run order (labels may repeat)
    units = {label_of(r): u for r, u in zip(runs, run_units)}
    figures = [("error_cdf", "Cumulative error distribution per category", plots.plot_error_cdf(units, out / "figures" / "error_cdf")),
               ("accuracy", "Accuracy against threshold", plots.plot_accuracy(units, out / "figures" / "accuracy")),
               ("runtime", "Runtime per registration", plots.plot_runtime({label_of(r): r.samples for r in runs},
                                                                            out / "figures" / "runtime"))]
    md += ["## Figures", ""]
    for name, caption, paths in figures:
        md += [f"### {caption}", "", f"![{caption}](figures/{name}.png)", "", f"[PDF](figures/{name}.pdf)", ""]

    if qualitative > 0:
        md += ["## Qualitative results", "", "Orange: the input carried into the template frame; blue-grey: the template.", ""]
        for i, (run, u) in enumerate(zip(runs, run_units)):
            label = label_of(run)
            view_rows = run.samples if run.protocol == "relative" else u  # pairs have no single sample
            for k, sid in enumerate(qualitative_picks(view_rows, qualitative)):
                stem = out / "figures" / f"sample_run{i}_{k}"
                try:
                    plots.plot_sample_from_run(run.path, sid, stem)
                    md += [f"**{label}**, `{sid}`:", "", f"![{sid}](figures/{stem.name}.png)", ""]
                except CatposeError as e:
                    md += [f"**{label}**, `{sid}`: not drawn ({e})", ""]
                    break
    index = out / "index.md"
    index.write_text("\n".join(md) + "\n")
    (out / "index.html").write_text(_html(md))
    return index


def _html(md_lines: list[str]) -> str:
    """A minimal HTML rendering of the index (tables as preformatted Markdown, images inline)."""
    import re

    body = []
    in_table = False
    for line in "\n".join(md_lines).splitlines():
        if line.startswith("|"):
            if not in_table:
                body.append("<pre>")
                in_table = True
            body.append(html.escape(line))
            continue
        if in_table:
            body.append("</pre>")
            in_table = False
        m = re.fullmatch(r"!\[(.*)\]\((.*)\)", line.strip())
        if m:
            body.append(f'<p><img src="{html.escape(m.group(2))}" alt="{html.escape(m.group(1))}" style="max-width:100%"></p>')
        elif line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            body.append(f"<h{level}>{html.escape(line.lstrip('#').strip())}</h{level}>")
        elif line.strip():
            text = html.escape(line)
            text = re.sub(r"\[([^\]]+)\]\(([^)]+)\)", r'<a href="\2">\1</a>', text)
            text = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", text)
            body.append(f"<p>{text}</p>")
    if in_table:
        body.append("</pre>")
    return "<!doctype html><html><head><meta charset='utf-8'><title>catpose report</title></head><body>\n" + \
        "\n".join(body) + "\n</body></html>\n"


def main(argv: list[str] | None = None) -> int:
    """``bench report RUN_DIR... --out DIR [--layout L ...] [--qualitative N]``."""
    from catpose.bench.tables import LAYOUTS, parse_labels

    ap = argparse.ArgumentParser(prog="bench report", description="Tables and figures of run directories in one folder.")
    ap.add_argument("runs", nargs="+", help="run directories, or folders searched for samples.jsonl")
    ap.add_argument("--out", required=True)
    ap.add_argument("--layout", action="append", choices=sorted(LAYOUTS), help="table layouts (default: generic)")
    ap.add_argument("--qualitative", type=int, default=0, help="pictures per run (re-loads samples from the config)")
    ap.add_argument("--label", action="append", default=[], help="RUN_DIR=LABEL, repeatable")
    args = ap.parse_args(argv)
    try:
        index = build_report(args.runs, args.out, args.layout or ["generic"], args.qualitative, parse_labels(args.label))
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"report written: {index} (and index.html)")
    return 0
