"""Paper tables from run directories (files only: ``samples.jsonl``, ``config.yaml``, ``run.json``).

A run directory is what the runner writes. Its per-sample rows are turned into scoring units by
the run's own protocol (``score_units``: templates keep the best-scored template per view,
``relative`` forms view pairs), summarised per category with :func:`catpose.bench.metrics.summarize`,
and laid out like the paper's tables:

==============  ================================================================================
layout          paper table
==============  ================================================================================
optimizer       \\compareoptimizerfull: pipeline/descriptor x method rows, category x {mean,
                median, L_T} columns
one_template    \\matchonetemplateplane: one category (airplane), {mean, median, @10, @30, L_T}
templates       \\templatechair: rows grouped by the number of templates (chair), oracle error
real            \\realdatatablesmall: category x metric rows, one column per method
tyol            \\TYOL: method x metric rows, one column per category (bottle ... mug)
ablation        \\ablationsvd: with and without optimisation, {mean, median, @10}
generic         any runs x categories x metrics
==============  ================================================================================

Best values are bold and second best underlined per column (or per row for ``real``), with the
direction of each metric (errors lower, accuracies higher). Output: Markdown, LaTeX or CSV.

Usage: ``bench table outputs/modelnet40-gt_model --layout optimizer --format latex``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from catpose.errors import CatposeError, ConfigError, DatasetError


# --------------------------------------------------------------------------------------------
# Runs


@dataclass
class Run:
    """One run directory read from disk.

    Attributes:
        path: the run directory.
        config: the resolved config (``config.yaml``) as a plain dict ({} when absent).
        info: ``run.json`` as a dict ({} when absent).
        samples: per-sample rows (pandas DataFrame with the ``samples.jsonl`` columns).
    """

    path: Path
    config: dict
    info: dict
    samples: Any

    @property
    def method(self) -> str:
        m = self.config.get("method")
        if isinstance(m, dict) and m.get("name"):
            return str(m["name"])
        if isinstance(m, str):
            return m
        if self.info.get("method"):
            return str(self.info["method"])
        if len(self.samples) and "method" in self.samples:
            return str(self.samples["method"].iloc[0])
        return self.path.name

    @property
    def protocol(self) -> str:
        p = self.config.get("protocol")
        if isinstance(p, dict) and p.get("name"):
            return str(p["name"])
        if isinstance(p, str):
            return p
        return str(self.info.get("protocol", "gt_model"))

    @property
    def method_config(self) -> dict:
        m = self.config.get("method")
        return m if isinstance(m, dict) else {}


def read_samples(path: Path):
    """A ``samples.jsonl`` as a DataFrame, one row per sample (the runner's reader: a truncated
    line of a killed run is skipped, a retried sample's last row counts)."""
    import pandas as pd

    from catpose.bench.rundir import latest_rows

    return pd.DataFrame(latest_rows(Path(path)))


def recompute_errors(samples):
    """Errors of every row recomputed from its estimate and ground truth by the runner's
    :func:`~catpose.bench.runner.recompute_errors` (symmetries included), so tables follow the
    current metric definitions rather than the numbers stored at run time."""
    import pandas as pd

    from catpose.bench.evaluate import recompute_errors as recompute_row

    if len(samples) == 0 or not {"T_est", "T_gt", "status"} <= set(samples.columns):
        return samples
    return pd.DataFrame([recompute_row(r) for r in samples.to_dict("records")], index=samples.index)


def load_run(path: str | Path) -> Run:
    """Read a run directory (``samples.jsonl`` required, ``config.yaml`` and ``run.json`` optional).

    Errors are recomputed from the stored poses (:func:`recompute_errors`).
    """
    path = Path(path)
    samples_path = path / "samples.jsonl"
    if not samples_path.is_file():
        raise DatasetError(f"{path} is not a run directory: {samples_path.name} is missing; pass a folder written by `bench run`")
    config: dict = {}
    if (path / "config.yaml").is_file():
        from omegaconf import OmegaConf

        config = OmegaConf.to_container(OmegaConf.load(path / "config.yaml"), resolve=False)  # type: ignore[assignment]
    info = json.loads((path / "run.json").read_text()) if (path / "run.json").is_file() else {}
    return Run(path=path, config=config, info=info, samples=recompute_errors(read_samples(samples_path)))


def find_run_dirs(paths: Sequence[str | Path]) -> list[Path]:
    """Run directories given directly or found below the given folders (sorted, no duplicates)."""
    from catpose.bench.merge import ensure_merged, is_sharded

    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():  # sharded runs: samples.jsonl from the shard files first (bench merge)
            for d in sorted({p} | {q.parent for q in p.rglob("samples.shard-*-of-*.jsonl")}):
                if is_sharded(d):
                    ensure_merged(d)
        if (p / "samples.jsonl").is_file():
            out.append(p)
        elif p.is_dir():
            found = sorted(q.parent for q in p.rglob("samples.jsonl"))
            if not found:
                raise DatasetError(f"no samples.jsonl below {p}; pass run directories written by `bench run`")
            out.extend(found)
        else:
            raise DatasetError(f"{p} does not exist; pass run directories written by `bench run`")
    seen: set[Path] = set()
    return [p for p in out if not (p.resolve() in seen or seen.add(p.resolve()))]


def protocol_of(run: Run):
    """The run's protocol, built from its ``config.yaml`` as the runner builds it; runs without a
    protocol config (external predictions written by hand) get the built-in protocol of their
    name."""
    cfg = run.config.get("protocol") if isinstance(run.config.get("protocol"), dict) else None
    if cfg and cfg.get("_target_"):
        from catpose.bench.build import build_from_config

        return build_from_config(dict(cfg), "protocol")[1]
    from catpose.bench.protocols import GtModel, Templates

    if run.protocol == "relative":
        from catpose.bench.relative import Relative

        return Relative()
    return Templates() if run.protocol == "templates" else GtModel()


def scored_units(run: Run, error: str = "err_deg"):
    """The run's scoring units (protocol ``score_units``); ``error="oracle_err_deg"`` uses the
    templates protocol's minimum error across templates as ``err_deg`` (an oracle)."""
    units = protocol_of(run).score_units(run.samples)
    if error != "err_deg":
        if error not in units:
            raise ConfigError(f"run {run.path} has no column {error!r}; the oracle exists only for the templates protocol")
        units = units.assign(err_deg=units[error])
    return units


# --------------------------------------------------------------------------------------------
# Labels

DISPLAY_NAMES = {"ours": "Ours", "icp": "ICP", "fgr": "FGR", "teaser": "TEASER (re-impl.)", "teaserpp": "Teaser++",
                 "teaser_pp": "Teaser++", "equipose": "Equi-pose", "equi_pose": "Equi-pose",
                 "rpmnet": "RPM-Net", "rpm_net": "RPM-Net", "ransac": "RANSAC"}


def _first(cfg: dict, keys: Sequence[str]) -> Any:
    for k in keys:
        if cfg.get(k) not in (None, ""):
            return cfg[k]
    return None


def pipeline_label(run: Run) -> str:
    """``"Dictionary LPS"``-style group label from the method's pipeline options, or ``"-"``."""
    cfg = run.method_config
    matching = _first(cfg, ("matching", "pipeline", "match"))
    if matching is None and run.method.lower().startswith("ours"):
        matching = "dictionary"  # our method always matches against the partial-template dictionary
    # baselines name their features; ours' descriptor is a config group node ({_target_: ...LPS, ...})
    descriptor = _first(cfg, ("features", "feature", "descriptor"))
    if isinstance(descriptor, dict):
        descriptor = str(descriptor.get("_target_", "")).rsplit(".", 1)[-1] or None
    parts = []
    if matching is not None:
        parts.append({"direct": "Direct match", "dictionary": "Dictionary"}.get(str(matching), str(matching)))
    if descriptor is not None:
        parts.append(str(descriptor).upper())
    return " ".join(parts) if parts else "-"


def without_optimisation(run: Run) -> bool:
    """Whether the method config switches the pose optimisation off (ablation runs)."""
    for k, v in run.method_config.items():
        if "optim" in k.lower() and isinstance(v, dict):  # ours: optimiser.mode
            v = v.get("mode")
        if "optim" in k.lower() and (v is False or str(v).lower() in ("none", "false", "off", "svd")):
            return True
        if k in ("steps", "n_steps", "opt_steps", "optim_steps", "iterations") and v == 0:
            return True
    return False


def method_label(run: Run) -> str:
    """Display name of the run's method (``Ours``, ``Teaser++``, ...), marking ablations."""
    name = DISPLAY_NAMES.get(run.method.lower(), run.method)
    return f"{name} (w/o optimization)" if without_optimisation(run) else name


def _flat(d: Any, prefix: str = "") -> dict[str, Any]:
    """A nested config as ``{"method.descriptor": "pfh", ...}``."""
    if not isinstance(d, dict):
        return {prefix: d}
    out: dict[str, Any] = {}
    for k, v in d.items():
        out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def _overrides(run: Run) -> list[str]:
    """The command-line overrides the runner recorded beside the run (``overrides.txt``)."""
    f = run.path / "overrides.txt"
    if not f.is_file():
        return []
    return [o.strip().lstrip("+~") for o in f.read_text().splitlines()
            if o.strip() and not o.startswith(("output_root", "progress", "print_summary", "hydra."))]


def _short(item: str) -> str:
    """``method.descriptor=pfh`` -> ``descriptor=pfh`` (the method is already in the label)."""
    return item[len("method."):] if item.startswith("method.") else item


def _distinguishing(members: Sequence[Run]) -> list[list[str]]:
    """Label suffixes that tell ``members`` (runs sharing a label) apart, the fewest kinds first:
    the protocol, the dataset, the recorded overrides not shared by all, the config values that
    differ, and only when nothing else does, the run directory's name (which ends in a hash)."""
    def dataset(r: Run) -> str:
        d = r.config.get("dataset")
        return str(d.get("name", "?")) if isinstance(d, dict) else str(r.info.get("dataset", "?"))

    def unique(parts: list[list[str]]) -> bool:
        return len({tuple(p) for p in parts}) == len(parts)

    parts: list[list[str]] = [[] for _ in members]
    if len({r.protocol for r in members}) > 1:
        parts = [p + [r.protocol] for p, r in zip(parts, members)]
    if not unique(parts) and len({dataset(r) for r in members}) > 1:
        parts = [p + [dataset(r)] for p, r in zip(parts, members)]
    if not unique(parts):
        overrides = [[o for o in _overrides(r) if o.split("=", 1)[0] not in ("protocol", "dataset")] for r in members]
        shared = set.intersection(*(set(o) for o in overrides))
        parts = [p + [_short(o) for o in sorted(ov) if o not in shared] for p, ov in zip(parts, overrides)]
    if not unique(parts):
        flats = [_flat({k: r.config.get(k) for k in ("method", "dataset", "protocol", "seed")}) for r in members]
        keys = sorted({k for f in flats for k in f if len({json.dumps(g.get(k), sort_keys=True, default=str) for g in flats}) > 1})
        parts = [p + [_short(f"{k}={f.get(k)}") for k in keys] for p, f in zip(parts, flats)]
    if not unique(parts):
        parts = [p + [r.path.name] for p, r in zip(parts, members)]
    return parts


def run_labels(runs: Sequence[Run], labels: dict[str, str] | None = None,
               group_of: Callable[[Run], str] = lambda r: "") -> list[str]:
    """One label per run (in order), unique within each row group ``group_of(run)``.

    The label is the user's (``labels``, see :func:`user_label`) or :func:`method_label`. Runs
    sharing a label and group keep it, pooled into one row, when they have the same protocol and
    disjoint categories (one run per category); otherwise each gets only what distinguishes it
    (:func:`_distinguishing`), e.g. ``Ours`` and ``Ours (descriptor=pfh)``, never a hash unless
    nothing else differs.
    """
    labels = labels or {}
    base = [user_label(r, labels) or method_label(r) for r in runs]
    keyed: dict[tuple[str, str], list[int]] = {}
    for i, r in enumerate(runs):
        keyed.setdefault((group_of(r), base[i]), []).append(i)
    out = list(base)
    for idx in keyed.values():
        members = [runs[i] for i in idx]
        cats = [set(r.samples["category"].astype(str)) if len(r.samples) else set() for r in members]
        if len(members) == 1 or (sum(map(len, cats)) == len(set().union(*cats)) and len({r.protocol for r in members}) == 1):
            continue
        for i, extra in zip(idx, _distinguishing(members)):
            out[i] = f"{base[i]} ({', '.join(extra)})" if extra else base[i]
    return out


def template_count(run: Run) -> str:
    """Number of templates per view of a templates run (from the rows, else the config)."""
    s = run.samples
    if run.protocol == "templates" and len(s) and "group_id" in s:
        return str(int(s.groupby("group_id").size().max()))
    p = run.config.get("protocol") if isinstance(run.config.get("protocol"), dict) else {}
    return str(p.get("max_templates") or ("1" if run.protocol != "templates" else "?"))


# --------------------------------------------------------------------------------------------
# Table model and rendering


@dataclass(frozen=True)
class Metric:
    """A statistic of :func:`catpose.bench.metrics.summarize` and how to show and rank it."""

    column: str
    md: str
    tex: str
    lower_is_better: bool
    digits: int = 3


METRICS: dict[str, Metric] = {
    "mean": Metric("mean_err_deg", "Mean° ↓", r"Mean$^{\circ}\downarrow$", True),
    "median": Metric("median_err_deg", "Med.° ↓", r"Med.$^{\circ}\downarrow$", True),
    "acc10": Metric("acc10", "@10 ↑", r"$@10\uparrow$", False),
    "acc30": Metric("acc30", "@30 ↑", r"$@30\uparrow$", False),
    "trans": Metric("mean_trans_err", "L_T ↓", r"$\mathcal{L}_T\downarrow$", True),
    "runtime": Metric("median_runtime_s", "time [s] ↓", r"time [s]$\downarrow$", True, 2),
    "n": Metric("n", "n", "n", False, 0),
    "failed": Metric("failed", "failed ↓", r"failed$\downarrow$", True, 0),
}


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
            sign = 1.0 if METRICS[m].lower_is_better else -1.0
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
        return f"{v:.{METRICS[m].digits}f}"


def _tex_escape(s: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("_", r"\_"), ("#", r"\#")):
        s = s.replace(a, b)
    return s


def _tex_label(label: str) -> str:
    """A metric's LaTeX header (``METRICS[...].tex``) or the escaped label."""
    for m in METRICS.values():
        if label == m.md:
            return m.tex
    return _tex_escape(label)


def to_markdown(table: Table) -> str:
    """GitHub Markdown: best in **bold**, second <u>underlined</u>."""
    ranks = table.ranks()
    head = table.row_header + [" ".join(x for x in c if x) for c in table.columns]
    lines = [f"**{table.title}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    prev: tuple = ()
    for r in table.rows:
        shown = [x if (k == len(r) - 1 or prev[: k + 1] != r[: k + 1]) else "" for k, x in enumerate(r)]
        prev = r
        cells = []
        for c in table.columns:
            t = table.text(r, c)
            rank = ranks.get((r, c))
            cells.append(f"**{t}**" if rank == 1 else f"<u>{t}</u>" if rank == 2 else t)
        lines.append("| " + " | ".join(shown + cells) + " |")
    lines += [""] + [f"{n}" for n in table.notes]
    return "\n".join(lines).rstrip() + "\n"


def to_latex(table: Table) -> str:
    """A booktabs ``tabular``: best in ``\\textbf``, second in ``\\underline``."""
    ranks = table.ranks()
    n_lead = len(table.row_header)
    two_level = any(len(c) > 1 for c in table.columns)
    spec = "l" * n_lead + " " + " ".join("c" for _ in table.columns)
    out = [r"\begin{table}[t]", r"\centering", rf"\caption{{{_tex_escape(table.title)}}}",
           r"\resizebox{\columnwidth}{!}{%", rf"\begin{{tabular}}{{{spec}}}", r"\toprule"]
    if two_level:
        spans: list[tuple[str, int]] = []
        for c in table.columns:
            if spans and spans[-1][0] == c[0]:
                spans[-1] = (c[0], spans[-1][1] + 1)
            else:
                spans.append((c[0], 1))
        top = [""] * n_lead + [rf"\multicolumn{{{n}}}{{c}}{{{_tex_escape(name)}}}" for name, n in spans]
        out.append(" & ".join(top) + r" \\")
    bottom = [rf"\textbf{{{_tex_escape(h)}}}" for h in table.row_header] + [_tex_label(c[-1]) for c in table.columns]
    out += [" & ".join(bottom) + r" \\", r"\midrule"]
    prev: tuple = ()
    for r in table.rows:
        if prev and n_lead > 1 and prev[0] != r[0]:
            out.append(r"\midrule")
        shown = [_tex_label(x) if (k == len(r) - 1 or prev[: k + 1] != r[: k + 1]) else ""
                 for k, x in enumerate(r)]
        prev = r
        cells = []
        for c in table.columns:
            t = table.text(r, c)
            rank = ranks.get((r, c))
            cells.append(rf"\textbf{{{t}}}" if rank == 1 else rf"\underline{{{t}}}" if rank == 2 else t)
        out.append(" & ".join(shown + cells) + r" \\")
    out += [r"\bottomrule", r"\end{tabular}%", "}", r"\end{table}"]
    return "\n".join(out) + "\n"


def to_csv(table: Table) -> str:
    """Plain CSV, one row per table row, full precision, no marks (empty for missing)."""
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


RENDERERS: dict[str, Callable[[Table], str]] = {"md": to_markdown, "latex": to_latex, "csv": to_csv}


# --------------------------------------------------------------------------------------------
# Layouts


@dataclass
class Entry:
    """The runs sharing one row label, pooled: per-category statistics."""

    group: str
    label: str
    summary: Any  # DataFrame from metrics.summarize, indexed by category


def user_label(run: Run, labels: dict[str, str]) -> str | None:
    """The label given for ``run`` (by its path as given, resolved, or its folder name)."""
    return labels.get(str(run.path)) or labels.get(str(run.path.resolve())) or labels.get(run.path.name)


def collect(runs: Sequence[Run], group_of: Callable[[Run], str], labels: dict[str, str] | None = None,
            error_of: Callable[[Run], str] = lambda r: "err_deg") -> list[Entry]:
    """Pool the scoring units of runs with the same (group, label) and summarise per category.

    ``labels`` maps a run directory (as given, or its name) to a user label; labels are made
    unique within a group by :func:`run_labels`. ``error_of`` names the error column each run is
    scored by (see :func:`scored_units`).
    """
    import pandas as pd

    from catpose.bench.metrics import summarize

    pooled: dict[tuple[str, str], list] = {}
    for run, label in zip(runs, run_labels(runs, labels, group_of)):
        pooled.setdefault((group_of(run), label), []).append(scored_units(run, error_of(run)))
    entries = []
    for (group, label), parts in pooled.items():
        summary = summarize(pd.concat(parts, ignore_index=True)).set_index("category")
        entries.append(Entry(group, label, summary))
    return entries


def _value(entry: Entry, category: str, metric: str) -> float:
    col = METRICS[metric].column
    if category not in entry.summary.index or col not in entry.summary.columns:
        return float("nan")
    return float(entry.summary.loc[category, col])


def _categories(entries: Sequence[Entry], wanted: Sequence[str] | None = None,
                defaults: Sequence[str] | None = None) -> list[str]:
    """User-given categories as they are; else the layout's defaults that some run has; else
    every category present (sorted)."""
    if wanted:
        return list(wanted)
    seen: list[str] = []
    for e in entries:
        seen += [c for c in e.summary.index if c != "all" and c not in seen]
    chosen = [c for c in defaults or [] if c in seen]
    return chosen or sorted(seen)


def grid_table(entries: Sequence[Entry], categories: Sequence[str], metrics: Sequence[str], title: str,
               grouped: bool = True, group_header: str = "Pipeline / Descriptor") -> Table:
    """Rows (group, method) x columns (category, metric); ranks per column."""
    rows = [(e.group, e.label) if grouped else (e.label,) for e in entries]
    cols = [(c.capitalize(), METRICS[m].md) for c in categories for m in metrics]
    t = Table(title, [group_header, "Methods"] if grouped else ["Methods"], rows, cols)
    for e, r in zip(entries, rows):
        for c in categories:
            for m in metrics:
                t.cells[(r, (c.capitalize(), METRICS[m].md))] = (_value(e, c, m), m)
    return t


def layout_generic(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                   metrics: Sequence[str] | None = None, title: str | None = "Results") -> Table:
    cats = _categories(entries, categories) + ([] if categories else ["all"])
    return grid_table(entries, cats, metrics or ["mean", "median", "acc10", "acc30", "trans"], title,
                      grouped=any(e.group not in ("", "-") for e in entries))


def layout_optimizer(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                     metrics: Sequence[str] | None = None, title: str | None = None) -> Table:
    return grid_table(entries, _categories(entries, categories, ["airplane", "chair", "car"]),
                      metrics or ["mean", "median", "trans"],
                      title or "Partial point cloud registration with the ground-truth complete shape")


def layout_one_template(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                        metrics: Sequence[str] | None = None, title: str | None = None) -> Table:
    return grid_table(entries, _categories(entries, categories, ["airplane"]), metrics or ["mean", "median", "acc10", "acc30", "trans"],
                      title or "Registration with one category-level template (airplane)")


def layout_templates(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                     metrics: Sequence[str] | None = None, title: str | None = None) -> Table:
    return grid_table(entries, _categories(entries, categories, ["chair"]), metrics or ["mean", "median", "acc10", "acc30"],
                      title or "Registration with several category-level templates (chair)",
                      group_header="Number of templates")


def layout_ablation(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                    metrics: Sequence[str] | None = None, title: str | None = None) -> Table:
    return grid_table(entries, _categories(entries, categories, ["airplane"]), metrics or ["mean", "median", "acc10"],
                      title or "Registration with and without the pose optimisation (airplane)", group_header="Setting")


def layout_real(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                metrics: Sequence[str] | None = None, title: str | None = None) -> Table:
    """Rows (category, metric) x one column per method; ranks across methods within a row."""
    cats = _categories(entries, categories, ["airplane", "chair", "car"])
    metrics = metrics or ["mean", "median", "acc10", "acc30"]
    cols = [(e.label,) for e in entries]
    rows = [(c.capitalize(), METRICS[m].md) for c in cats for m in metrics]
    t = Table(title or "Pairwise relative pose between two partial views of real scans",
              ["Category", "Metric"], rows, cols, rank_by="row")
    for e, col in zip(entries, cols):
        for c in cats:
            for m in metrics:
                t.cells[((c.capitalize(), METRICS[m].md), col)] = (_value(e, c, m), m)
    return t


def layout_tyol(entries: Sequence[Entry], categories: Sequence[str] | None = None,
                metrics: Sequence[str] | None = None, title: str | None = None) -> Table:
    """Rows (method, metric) x one column per category; ranks across methods per column and metric."""
    cats = _categories(entries, categories, ["bottle", "bowl", "can", "plate", "mug"])
    metrics = metrics or ["mean", "median", "acc10", "acc30"]
    rows = [(e.label, METRICS[m].md) for e in entries for m in metrics]
    cols = [(c.capitalize(),) for c in cats]
    t = Table(title or "Camera pose estimation on TYO-L (symmetric objects by main-axis error)",
              ["Methods", "Metric"], rows, cols, rank_by="column")
    for e in entries:
        for m in metrics:
            for c in cats:
                t.cells[((e.label, METRICS[m].md), (c.capitalize(),))] = (_value(e, c, m), m)
    return t


LAYOUTS: dict[str, tuple[Callable[..., Table], Callable[[Run], str], str]] = {
    # name: (layout, row group of a run, default error column)
    "generic": (layout_generic, lambda r: "", "err_deg"),
    "optimizer": (layout_optimizer, pipeline_label, "err_deg"),
    "one_template": (layout_one_template, pipeline_label, "err_deg"),
    "templates": (layout_templates, template_count, "oracle_err_deg"),
    "ablation": (layout_ablation, lambda r: f"{r.protocol} {pipeline_label(r)}".replace(" -", ""), "err_deg"),
    "real": (layout_real, lambda r: "", "err_deg"),
    "tyol": (layout_tyol, lambda r: "", "err_deg"),
}


def build_table(runs: Sequence[Run], layout: str = "generic", categories: Sequence[str] | None = None,
                metrics: Sequence[str] | None = None, labels: dict[str, str] | None = None,
                error: str | None = None, title: str | None = None) -> Table:
    """Lay out ``runs`` as one of :data:`LAYOUTS`.

    ``error`` picks the per-unit error: ``"err_deg"`` (the method's own choice) or
    ``"oracle_err_deg"`` (templates protocol: minimum across templates); the ``templates``
    layout defaults to the oracle, as in the paper, and says so in a note.
    """
    if layout not in LAYOUTS:
        raise ConfigError(f"unknown table layout {layout!r}; use one of {sorted(LAYOUTS)}")
    for m in metrics or []:
        if m not in METRICS:
            raise ConfigError(f"unknown metric {m!r}; use some of {sorted(METRICS)}")
    fn, group_of, default_error = LAYOUTS[layout]
    error = error or default_error
    # Only templates runs have an oracle; other runs in the same table keep their own error.
    oracle = error == "oracle_err_deg"
    entries = collect(runs, group_of, labels,
                      lambda r: "oracle_err_deg" if oracle and r.protocol == "templates" else "err_deg")
    # Paper order: pipelines from plain to ours, and within one, our method last.
    entries.sort(key=lambda e: (_group_order(e.group), e.group, e.label.startswith("Ours")))
    kwargs = {"title": title} if title else {}
    table = fn(entries, categories=list(categories) if categories else None, metrics=list(metrics) if metrics else None, **kwargs)
    prune(table)
    if oracle and any(r.protocol == "templates" for r in runs):
        table.notes.append("Errors of templates runs are the minimum across templates (an oracle that needs ground truth).")
    return table


def split_by_protocol(runs: Sequence[Run]) -> dict[str, list[Run]]:
    """Runs per protocol (in first-seen order): errors of different protocols answer different
    questions, so the report gives each its own tables and figures."""
    out: dict[str, list[Run]] = {}
    for r in runs:
        out.setdefault(r.protocol, []).append(r)
    return out


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


def _group_order(group: str) -> int:
    order = ["-", "", "Direct match FPFH", "Dictionary FPFH", "Dictionary PFH", "Dictionary LPS"]
    if group.isdigit():
        return int(group)
    return order.index(group) if group in order else len(order)


def parse_labels(items: Sequence[str]) -> dict[str, str]:
    """``["runs/a=Ours (LPS)", ...]`` -> ``{"runs/a": "Ours (LPS)"}``.

    Run directories contain ``=`` (``seed0-method.lr=0.01-<hash>``), labels rarely do, so the
    item is split at its last ``=``."""
    out = {}
    for item in items:
        key, sep, value = item.rpartition("=")
        if not sep or not value:
            raise ConfigError(f"--label {item!r} must be RUN_DIR=LABEL")
        out[str(Path(key))] = value
        out[str(Path(key).resolve())] = value  # the same run however its path is spelled
    return out


def sweep_runs(sweep_dirs: Sequence[str | Path]) -> tuple[list[Path], dict[str, str], dict[str, Any]]:
    """Run directories, labels and table settings of sweeps (``bench run -m``).

    Reads each job's ``job.json`` (:mod:`catpose.bench.sweep`) and the sweep's ``multirun.yaml``,
    whose ``table`` node (set by ``configs/experiment/*.yaml``) gives ``layout``, ``categories``,
    ``metrics``, ``error`` and ``title``. A failed or unfinished job stops the table with a
    one-line error naming it."""
    from catpose.bench.sweep import read_sweep

    paths: list[Path] = []
    labels: dict[str, str] = {}
    settings: dict[str, Any] = {}
    for d in map(Path, sweep_dirs):
        records = read_sweep(d)
        if not records:
            raise DatasetError(f"{d} is not a sweep directory (no */job.json); pass <output_root>/multirun/<name>/<time> "
                               f"of a `bench run -m` that has finished")
        bad = [r for r in records if r.get("status") != "ok" or not r.get("run_dir")]
        if bad:
            raise DatasetError(f"sweep {d}: job {bad[0].get('job')} ({' '.join(bad[0].get('overrides') or [])}) failed: "
                               f"{bad[0].get('error')}; re-run the sweep (finished samples are skipped)")
        for r in records:
            run_dir = Path(r["run_dir"])
            if run_dir not in paths:
                paths.append(run_dir)
            if r.get("label"):
                labels.update({str(run_dir): r["label"], str(run_dir.resolve()): r["label"]})
        if (d / "multirun.yaml").is_file() and not settings:
            from omegaconf import OmegaConf

            table = OmegaConf.to_container(OmegaConf.load(d / "multirun.yaml"), resolve=False).get("table") or {}
            settings = {k: v for k, v in table.items() if k in ("layout", "categories", "metrics", "error", "title")}
    if settings.get("layout") not in (None, *LAYOUTS):
        raise ConfigError(f"the sweep's table.layout {settings['layout']!r} is not one of {sorted(LAYOUTS)}")
    return paths, labels, settings


def main(argv: list[str] | None = None) -> int:
    """``bench table RUN_DIR... [--sweep DIR] [--layout L] [--format md|latex|csv] [--out FILE]``."""
    ap = argparse.ArgumentParser(prog="bench table", description="Paper tables from run directories.")
    ap.add_argument("runs", nargs="*", help="run directories, or folders searched for samples.jsonl")
    ap.add_argument("--sweep", action="append", default=[], metavar="DIR",
                    help="a sweep directory of `bench run -m` (<output_root>/multirun/<name>/<time>): its jobs' "
                         "runs and labels, and the experiment's table settings (repeatable)")
    ap.add_argument("--layout", default=None, choices=sorted(LAYOUTS), help="default: the sweep's, else generic")
    ap.add_argument("--format", default="md", choices=sorted(RENDERERS))
    ap.add_argument("--categories", default=None, help="comma-separated categories (default: the layout's)")
    ap.add_argument("--metrics", default=None, help=f"comma-separated, of {','.join(METRICS)}")
    ap.add_argument("--label", action="append", default=[], help="RUN_DIR=LABEL, repeatable")
    ap.add_argument("--error", default=None, choices=["err_deg", "oracle_err_deg"],
                    help="the method's own choice or the minimum across templates (oracle)")
    ap.add_argument("--title", default=None)
    ap.add_argument("--out", default=None, help="write here instead of stdout")
    ap.add_argument("--bop-metrics", default=None,
                    help="BOP recalls of runs scored by `bench score` (bop_errors.jsonl), e.g. "
                         "ar_mssd,ar_mspd,adds@0.1,5deg5cm (see catpose.bench.bop_eval.parse_metric)")
    ap.add_argument("--by", default="object,category", help="with --bop-metrics: rows per object and/or category")
    args = ap.parse_args(argv)
    try:
        run_paths, sweep_labels, defaults = sweep_runs(args.sweep)
        if not args.runs and not run_paths:
            raise ConfigError("no runs: pass run directories or --sweep DIR (a sweep directory of `bench run -m`)")
        if args.bop_metrics:
            from catpose.bench.bop_eval import table_main_from_runs

            text = table_main_from_runs(find_run_dirs([*args.runs, *run_paths]), args.bop_metrics.split(","),
                                        args.by.split(",")) + "\n"
            Path(args.out).write_text(text) if args.out else sys.stdout.write(text)
            return 0
        if args.layout not in (None, defaults.get("layout")):
            defaults = {}  # another layout than the experiment's: none of its settings apply
        for key, value in defaults.items():  # the experiment's settings, unless given here
            if getattr(args, key) is None and value:
                setattr(args, key, ",".join(map(str, value)) if isinstance(value, list) else str(value))
        args.layout = args.layout or "generic"
        runs = [load_run(p) for p in find_run_dirs([*args.runs, *run_paths])]
        table = build_table(runs, args.layout, args.categories.split(",") if args.categories else None,
                            args.metrics.split(",") if args.metrics else None,
                            {**sweep_labels, **parse_labels(args.label)}, args.error, args.title)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = RENDERERS[args.format](table)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text)
    else:
        sys.stdout.write(text)
    return 0
