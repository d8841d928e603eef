"""``bench report``: tables and figures of run directories in one folder a person can open.

    bench report outputs/synthetic-gt_model --out report/ [--no-pictures]

writes ``index.md`` (every link relative) and, per protocol (they never share a table or figure),
``tables/<protocol>_{summary,per_category}.{md,tex,csv}`` (other layouts: ``bench table``),
``figures/<protocol>_{error_cdf,accuracy}.{png,pdf,csv}`` (the CSV holds the plotted data) and a
picture of each run's worst registration (``--no-pictures``: none); speed is ``bench perf``'s.
The folder is built beside ``--out`` and moved into place whole
(:func:`catpose.bench.run.overwrite.check_output`)."""

from __future__ import annotations

import argparse
import functools
import os
import re
from collections.abc import Sequence
from pathlib import Path

from catpose import atomic
from catpose.bench.report import plots, tables
from catpose.bench.report.labels import parse_labels, run_labels
from catpose.bench.report.runs import load_runs, print_left_out, scored_units
from catpose.errors import CatposeError

PROTOCOL_TEXT = {
    "gt_model": "each partial view registered to its own complete model",
    "templates": "each partial view registered to the category templates; the estimate is the one the run's template choice keeps (its `choice`, `fused` by default)",
    "relative": "relative pose between two views of one object, each registered to the category templates",
}


def worst_drawable(units) -> str | None:
    """The ``sample_id`` of the unit with the largest error among those with an estimate (the last
    in file order among equals), None when no unit has one (``status != "ok"``: nothing to draw)."""
    if len(units) == 0 or "T_est" not in units:
        return None
    ok = units[(units["status"] == "ok") & units["T_est"].notna()]
    return None if len(ok) == 0 else str(ok.sort_values("err_deg", kind="stable").iloc[-1]["sample_id"])


def _units_by_label(labels: list[str], units: list) -> dict:
    """Scoring units per label; runs that share a label (one run per category) are pooled."""
    import pandas as pd

    out: dict[str, list] = {}
    for label, u in zip(labels, units):
        out.setdefault(label, []).append(u)
    return {k: pd.concat(v, ignore_index=True) for k, v in out.items()}


def _relative_names(paths: Sequence[Path]) -> tuple[str, list[str]]:
    """The runs' common folder (its name only) and each run's path below it."""
    root = Path(os.path.commonpath([str(p.resolve().parent) for p in paths]))
    return root.name, [str(p.resolve().relative_to(root)) for p in paths]


def _git_rev(run) -> str:
    f = run.path / "git_rev.txt"
    return f.read_text().strip()[:10] if f.is_file() else "?"


def _write_table(table, out: Path, stem: str) -> list[str]:
    for fmt, ext in (("md", "md"), ("latex", "tex"), ("csv", "csv")):
        atomic.write_text(out / "tables" / f"{stem}.{ext}", tables.RENDERERS[fmt](table))
    return [
        tables.to_markdown(table),
        f"Files: [md](tables/{stem}.md), [LaTeX](tables/{stem}.tex), [CSV](tables/{stem}.csv)",
        "",
    ]


#: the summary table's columns (all categories pooled), as the README quotes it
SUMMARY_METRICS = ("mean", "median", "acc10", "acc30", "trans", "runtime", "failed")


def protocol_tables(runs: Sequence, labels: dict[str, str] | None, protocol: str, allow_mixed: bool = False) -> dict:
    """A report's tables of one protocol, ``tables/<protocol>_<name>.*``: ``summary``, one row per
    run with all categories pooled and the columns of :data:`SUMMARY_METRICS` named by the metric
    alone (the README's first table), and, when the runs name categories, ``per_category``, a row
    block per run and a column per category (the paper's layout) with mean, median, @10 and @30;
    ``make demo`` prints both."""
    table = functools.partial(tables.build_table, runs, labels=labels, allow_mixed=allow_mixed)
    summary = table(
        "generic", categories=["all"], metrics=list(SUMMARY_METRICS), title=f"All categories pooled ({protocol})"
    )
    # One category ("all"): the metric alone names each column.
    summary.cells = {(r, c[1:]): v for (r, c), v in summary.cells.items()}
    summary.columns = [c[1:] for c in summary.columns]
    cats = sorted({str(c) for r in runs for c in r.samples.get("category", [])})
    if not cats:
        return {"summary": summary}
    per_category = table(
        "tyol", categories=cats, metrics=["mean", "median", "acc10", "acc30"], title=f"Per category ({protocol})"
    )
    return {"summary": summary, "per_category": per_category}


def build_report(
    run_dirs: Sequence[str | Path],
    out: str | Path,
    pictures: bool = False,
    labels: Sequence[str] = (),
    notes: Sequence[str] = (),
    pdf: bool = True,
    left_out: list[str] | None = None,
    allow_mixed: bool = False,
) -> Path:
    """Write the report folder (see the module docstring); returns the path of ``index.md``.

    ``labels``: ``--label RUN_DIR=LABEL`` items (each must name a run);
    ``notes``: paragraphs under the title; ``pdf``: a PDF of each summary figure too; ``pictures``:
    each run's worst registration drawn. Runs of one protocol on different samples are refused
    unless ``allow_mixed``. A run that cannot be read is left out, said in the index and on stderr,
    and its reason appended to ``left_out``. The folder is built aside and moved into place whole."""
    runs, reasons = load_runs(run_dirs)
    label_of = parse_labels(labels, runs)
    print_left_out("report", runs, reasons)
    if left_out is not None:
        left_out.extend(reasons)
    final = Path(out)
    with atomic.building_dir(final) as out:  # built aside, moved into place whole (docs/file-safety.md)
        _write_report(runs, reasons, out, pictures, label_of, notes, pdf, allow_mixed)
    return final / "index.md"


def _write_report(runs, reasons, out: Path, pictures, labels, notes, pdf, allow_mixed: bool = False) -> None:
    """The files of :func:`build_report` into the new, empty folder ``out``."""
    (out / "tables").mkdir(parents=True, exist_ok=True)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    by_protocol = tables.split_by_protocol(runs)
    label_of = {id(r): lab for group in by_protocol.values() for r, lab in zip(group, run_labels(group, labels))}

    # One colour per label across the protocols' figures.
    colors = {lab: f"C{k % 10}" for k, lab in enumerate(dict.fromkeys(label_of[id(r)] for r in runs))}
    root, rel = _relative_names([r.path for r in runs])
    md = ["# catpose report", ""] + [x for n in notes for x in (n, "")]
    md += [
        f"Built from these run directories (below their common folder `{root}/`; revision = the git "
        "revision each run was made at):",
        "",
        "| Label | Protocol | Run directory | Samples | Revision |",
        "|---|---|---|---|---|",
    ]
    for run, path in zip(runs, rel):
        md.append(f"| {label_of[id(run)]} | {run.protocol} | `{path}` | {len(run.samples)} | `{_git_rev(run)}` |")
    md.append("")
    if reasons:
        md += ["Left out (unreadable):", ""] + [f"- {why}" for why in reasons] + [""]

    for protocol, group in by_protocol.items():
        names = {str(r.path): label_of[id(r)] for r in group}
        group_labels = [label_of[id(r)] for r in group]
        md += [
            f"## Protocol `{protocol}`",
            "",
            f"{PROTOCOL_TEXT.get(protocol, protocol).capitalize()}.",
            "",
            "### Tables",
            "",
        ]
        for name, table in protocol_tables(group, names, protocol, allow_mixed).items():
            md += _write_table(table, out, f"{protocol}_{name}")

        run_units = [scored_units(r) for r in group]
        units = _units_by_label(group_labels, run_units)
        fig = out / "figures"
        md += ["### Figures", ""]
        for name, caption, plot in (
            ("error_cdf", "Cumulative error distribution per category", plots.plot_error_cdf),
            ("accuracy", "Accuracy at thresholds", plots.plot_accuracy),
        ):
            paths = plot(units, fig / f"{protocol}_{name}", pdf=pdf, colors=colors)
            links = ", ".join(f"[{p.suffix[1:].upper()}](figures/{p.name})" for p in paths[1:])
            md += [f"#### {caption}", "", f"![{caption}](figures/{paths[0].name})", "", f"Data and vector: {links}", ""]

        if pictures:
            md += [
                "### Examples: the worst registration per method",
                "",
                "Orange: the input carried into the template frame (left: by the estimate, right: by the truth); "
                "blue-grey: the template.",
                "",
            ]
            for run, label, u in zip(group, group_labels, run_units):
                view_rows = run.samples if run.protocol == "relative" else u  # pairs have no single sample
                sid = worst_drawable(view_rows)
                if sid is None:
                    md += [f"**{label}**: no registration with an estimate to draw.", ""]
                    continue
                err = float(view_rows.loc[view_rows["sample_id"] == sid, "err_deg"].iloc[-1])
                stem = fig / f"{protocol}_{re.sub(r'[^A-Za-z0-9]+', '_', label).strip('_')}_worst"
                try:
                    plots.plot_sample_from_run(run, sid, stem, f"{label} | {sid} | worst", pdf=False)
                except CatposeError as e:
                    md += [f"**{label}**, worst `{sid}` ({err:.1f} deg): not drawn ({e})", ""]
                    continue
                md += [
                    f"**{label}**, worst: `{sid}`, {err:.1f} deg",
                    "",
                    f"![{label} worst](figures/{stem.name}.png)",
                    "",
                ]

    atomic.write_text(out / "index.md", "\n".join(md) + "\n")


def main(argv: list[str] | None = None) -> int:
    """``bench report RUN_DIR... --out DIR [--no-pictures] [--note TEXT ...]``."""
    from catpose.bench.run.overwrite import Output, add_output_options, input_runs

    ap = argparse.ArgumentParser(
        prog="bench report", description="Tables and figures of run directories in one folder."
    )
    ap.add_argument("runs", nargs="+", help="run directories, or folders searched for samples.jsonl")
    add_output_options(ap, "the report folder to write (new or empty; see --force)")
    ap.add_argument(
        "--no-pictures",
        action="store_true",
        help="no picture of each run's worst registration (they re-load its sample from the run's config)",
    )
    ap.add_argument("--label", action="append", default=[], help="RUN_DIR=LABEL, repeatable")
    ap.add_argument("--note", action="append", default=[], help="a paragraph under the title (how the runs were made)")
    ap.add_argument("--no-pdf", action="store_true", help="figures as PNG (+ CSV) only")
    ap.add_argument(
        "--allow-mixed",
        action="store_true",
        help="tables of runs on different datasets, seeds or sample sets (refused otherwise), said in a note",
    )
    args = ap.parse_args(argv)
    out = Output(args.out, "folder", input_runs(args.runs), args.force)  # before any work
    left_out: list[str] = []
    with out.writing():
        index = build_report(
            args.runs,
            args.out,
            not args.no_pictures,
            args.label,
            args.note,
            pdf=not args.no_pdf,
            left_out=left_out,
            allow_mixed=args.allow_mixed,
        )
    print(f"report written: {index}" + (f"; {len(left_out)} run(s) left out" if left_out else ""))
    return 2 if left_out else 0
