"""Figures from run directories (matplotlib, Agg backend). The aggregate ones come with a CSV of
what they plot: :func:`plot_error_cdf` (the error's cumulative distribution per method, a panel
per category, log error axis) and :func:`plot_accuracy` (accuracy at thresholds, categories
pooled); their inputs are per-method tables of scoring units (``{label: DataFrame}`` with
``category``, ``status``, ``err_deg``), failed units counting as 180 degrees everywhere. One
registration is drawn in 3D by :func:`plot_registration` (the observed points carried into the
template frame by the estimate, over the template, next to the same with the ground truth), and
for a sample of a run by :func:`plot_sample_from_run`, rebuilt from the run's ``config.yaml``
since the run stores no points. Speed is ``bench perf``'s (docs/speed.md)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from catpose import atomic
from catpose.bench.scoring.curves import scored_errors
from catpose.bench.scoring.metrics import FAILED_ERROR_DEG, accuracy

#: The CDF's log axis starts at 0.01 degrees, or lower (down to 1e-4) when smaller errors occur;
#: errors below the start are drawn at it (a log axis has no zero).
CDF_FLOOR_DEG = 0.01
CDF_MIN_FLOOR_DEG = 1e-4


def cdf_floor(errors: np.ndarray) -> float:
    """Where the CDF's log error axis starts (degrees): a power of ten at or below every
    positive error, within [:data:`CDF_MIN_FLOOR_DEG`, :data:`CDF_FLOOR_DEG`]."""
    e = np.asarray(errors, float)
    e = e[np.isfinite(e) & (e > 0)]
    if not len(e):
        return CDF_FLOOR_DEG
    return float(np.clip(10.0 ** np.floor(np.log10(e.min())), CDF_MIN_FLOOR_DEG, CDF_FLOOR_DEG))


#: Thresholds (degrees) of the accuracy bars.
ACCURACY_THRESHOLDS_DEG = (1.0, 2.0, 5.0, 10.0, 30.0)


def pyplot():
    """matplotlib.pyplot on the Agg backend (files only, no display)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def save(fig, out_stem: str | Path, pdf: bool = True, dpi: int = 150) -> list[Path]:
    """Write ``<out_stem>.png`` (and ``<out_stem>.pdf`` when ``pdf``); close the figure; return the paths."""
    out_stem = Path(out_stem)
    out_stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [out_stem.with_suffix(".png")] + ([out_stem.with_suffix(".pdf")] if pdf else [])
    for path in paths:
        with atomic.atomic_path(path) as tmp:
            # no creation date in a PDF: the same figure is the same bytes (results/ regenerate byte for byte)
            meta = {"CreationDate": None} if path.suffix == ".pdf" else None
            fig.savefig(tmp, dpi=dpi, bbox_inches="tight", format=path.suffix[1:], metadata=meta)
    pyplot().close(fig)
    return paths


def _colors(labels, colors: Mapping[str, str] | None) -> dict[str, str]:
    """A colour per label: the given ones, else the default cycle in label order."""
    colors = colors or {}
    return {label: colors.get(label, f"C{m % 10}") for m, label in enumerate(labels)}


def _write_csv(rows: list[dict], columns: list[str], out_stem: str | Path) -> Path:
    import pandas as pd

    path = Path(out_stem).with_suffix(".csv")
    atomic.write_text(path, pd.DataFrame(rows, columns=columns).to_csv(index=False, float_format="%.6g"))
    return path


def cdf_points(errors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The empirical CDF's step points: sorted errors (degrees) and the fraction <= each, (N,) each."""
    e = np.sort(np.asarray(errors, float))
    return e, np.arange(1, len(e) + 1) / max(len(e), 1)


def plot_error_cdf(
    units_by_method: Mapping[str, object],
    out_stem: str | Path,
    pdf: bool = True,
    colors: Mapping[str, str] | None = None,
) -> list[Path]:
    """Cumulative distribution of the error per method, one panel per category (log error axis).

    Writes ``<out_stem>.csv`` with columns ``method, category, n, error_deg, fraction`` (the
    step points, errors as scored, not floored). Returns the PNG (, PDF) and CSV paths.
    ``colors`` maps labels to matplotlib colours (default: the colour cycle in order).
    """
    plt = pyplot()
    color = _colors(units_by_method, colors)
    categories = sorted({c for u in units_by_method.values() for c in u["category"].astype(str)})
    n = max(len(categories), 1)
    cols = min(n, 4)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.0 * rows + 0.6), squeeze=False, sharey=True)
    csv_rows: list[dict] = []
    floor = cdf_floor(np.concatenate([scored_errors(u) for u in units_by_method.values()] or [np.zeros(0)]))
    for ax, cat in zip(axes.ravel(), categories):
        counts = []
        for label, units in units_by_method.items():
            u = units[units["category"].astype(str) == cat]
            if len(u) == 0:
                continue
            e, y = cdf_points(scored_errors(u))
            counts.append(len(e))
            csv_rows += [
                {"method": label, "category": cat, "n": len(e), "error_deg": a, "fraction": b} for a, b in zip(e, y)
            ]
            x = np.clip(e, floor, FAILED_ERROR_DEG)
            # One colour per method across panels; the curve starts at 0 on the left edge.
            ax.step(
                np.concatenate([[floor], x, [FAILED_ERROR_DEG]]),
                np.concatenate([[0], y, [y[-1]]]),
                where="post",
                color=color[label],
                lw=1.6,
                alpha=0.9,
                label=label,
            )
        for t in (10, 30):
            ax.axvline(t, color="grey", lw=0.7, ls="--")
        ax.set_title(f"{cat} (n={'/'.join(map(str, sorted(set(counts))))})", fontsize=10)
        ax.set_xscale("log")
        ax.set_xlim(floor, FAILED_ERROR_DEG * 1.15)
        ticks = [t for t in (1e-4, 1e-3, 0.01, 0.1, 1, 10, 180) if t >= floor]
        ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
    for ax in axes[-1, :]:
        ax.set_xlabel("error [deg], log")
    for ax in axes[:, 0]:
        ax.set_ylabel("fraction <= error")
    spare = axes.ravel()[len(categories) :]
    for ax in spare:
        ax.axis("off")
    handles: dict[str, object] = {}
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.suptitle("Cumulative error distribution per category (rotation; main axis for symmetric objects)", fontsize=11)
    note = (
        f"errors below {floor:g} deg drawn at {floor:g};\nfailures count as "
        f"{FAILED_ERROR_DEG:g} deg; dashed: 10 and 30 deg"
    )
    legend = dict(handles=list(handles.values()), labels=list(handles), fontsize=9, frameon=False)
    if len(spare):  # the legend goes into the first empty panel, beside the curves
        spare[0].legend(**legend, loc="upper left", title=note, title_fontsize=9, alignment="left")
        fig.tight_layout(rect=(0, 0, 1, 0.97))
    else:  # the legend and the note below the panels, in the figure's text size
        ncol = min(len(handles), 4) or 1
        legend_rows = int(np.ceil(len(handles) / ncol))
        fig.legend(**legend, loc="lower center", ncol=ncol, bbox_to_anchor=(0.5, 0.02 / rows))
        fig.text(0.5, 0.003, note.replace("\n", " "), ha="center", va="bottom", fontsize=9, color="0.25")
        fig.tight_layout(rect=(0, (0.05 + 0.04 * legend_rows) / rows, 1, 0.97))
    csv = _write_csv(csv_rows, ["method", "category", "n", "error_deg", "fraction"], out_stem)
    return save(fig, out_stem, pdf) + [csv]


def plot_accuracy(
    units_by_method: Mapping[str, object],
    out_stem: str | Path,
    thresholds=ACCURACY_THRESHOLDS_DEG,
    pdf: bool = True,
    colors: Mapping[str, str] | None = None,
) -> list[Path]:
    """Accuracy (fraction with error <= threshold) at ``thresholds`` (degrees), categories pooled:
    one group of bars per threshold, one bar per method, its value written above it.

    Writes ``<out_stem>.csv`` with columns ``method, threshold_deg, n, accuracy``.
    """
    plt = pyplot()
    color = _colors(units_by_method, colors)
    items = [(label, scored_errors(u)) for label, u in units_by_method.items()]
    items = [(label, e) for label, e in items if len(e)]
    k = max(len(items), 1)
    width = 0.8 / k
    fig, ax = plt.subplots(figsize=(max(5.0, 1.2 * len(thresholds) * (0.6 + 0.25 * k)), 3.8))
    x = np.arange(len(thresholds))
    csv_rows = []
    for m, (label, e) in enumerate(items):
        acc = np.array([accuracy(e, t) for t in thresholds])
        bars = ax.bar(x - 0.4 + width * (m + 0.5), acc, width, color=color[label], label=label)
        ax.bar_label(bars, [f"{a:.2f}" for a in acc], fontsize=7, padding=1, rotation=90 if k > 3 else 0)
        csv_rows += [{"method": label, "threshold_deg": t, "n": len(e), "accuracy": a} for t, a in zip(thresholds, acc)]
    ax.set_xticks(x, [f"<= {t:g} deg" for t in thresholds], fontsize=9)
    ax.set_ylim(0, 1.18)
    ax.set_yticks(np.linspace(0, 1, 6))
    ax.set_ylabel("fraction of samples")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8, loc="upper left", ncol=min(k, 3), frameon=False)
    ax.set_title("Accuracy at thresholds (all categories; failures count as wrong)", fontsize=10)
    fig.tight_layout()
    csv = _write_csv(csv_rows, ["method", "threshold_deg", "n", "accuracy"], out_stem)
    return save(fig, out_stem, pdf) + [csv]


def _scatter(ax, points: np.ndarray, color: str, size: float, label: str, max_points: int = 3000) -> None:
    if len(points) > max_points:
        points = points[np.linspace(0, len(points) - 1, max_points).astype(int)]
    ax.scatter(points[:, 0], points[:, 1], points[:, 2], s=size, c=color, label=label, depthshade=False)


def plot_registration(
    points_camera: np.ndarray,
    template_points: np.ndarray,
    T_est: np.ndarray | None,
    T_gt: np.ndarray | None,
    out_stem: str | Path,
    title: str = "",
    err_deg: float | None = None,
    pdf: bool = True,
) -> list[Path]:
    """The input (orange) carried into the template frame over the template (blue-grey).

    Args:
        points_camera: (N, 3) observed points, camera frame.
        template_points: (M, 3) template points, template frame.
        T_est, T_gt: (4, 4) estimated / true ``T_template_camera`` (either may be None).
    """
    from catpose.geometry import transform_points

    plt = pyplot()
    panels = [(T, name) for T, name in ((T_est, "estimate"), (T_gt, "ground truth")) if T is not None]
    fig = plt.figure(figsize=(4.2 * max(len(panels), 1), 4.2))
    lim = 1.1 * max(1.0, float(np.abs(template_points).max()))
    for k, (T, name) in enumerate(panels, 1):
        ax = fig.add_subplot(1, len(panels), k, projection="3d")
        _scatter(ax, template_points, "#8fa8c8", 1.0, "template")
        _scatter(ax, transform_points(np.asarray(T, float), points_camera), "#e8751a", 2.0, "input")
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_zlim(-lim, lim)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=20, azim=-60)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z (up)")
        sub = f" ({err_deg:.1f} deg)" if name == "estimate" and err_deg is not None else ""
        ax.set_title(f"{name}{sub}", fontsize=9)
        if k == 1:
            ax.legend(fontsize=7, loc="upper left", markerscale=4)
    fig.suptitle(title, fontsize=9)
    return save(fig, out_stem, pdf, dpi=110)


def plot_sample_from_run(
    run, sample_id: str, out_stem: str | Path, title: str | None = None, pdf: bool = True
) -> list[Path]:
    """Re-load ``sample_id`` of ``run`` (a :class:`~catpose.bench.report.runs.Run`) from its config
    (dataset + protocol) and plot its registration (``title`` defaults to ``method | sample | status``).

    Raises :class:`~catpose.errors.CatposeError` when the dataset cannot be rebuilt here.
    """
    from catpose.errors import CatposeError, ConfigError, DatasetError

    run_dir = run.path
    rows = run.samples[run.samples["sample_id"] == sample_id]
    if len(rows) == 0:
        raise DatasetError(f"sample {sample_id!r} is not in {run_dir}/samples.jsonl")
    row = rows.iloc[-1]
    cfg = run.config
    if not isinstance(cfg.get("dataset"), dict) or not isinstance(cfg.get("protocol"), dict):
        raise ConfigError(f"{run_dir}/config.yaml has no dataset/protocol to re-load samples from")
    from catpose.bench.run.build import build_from_config, build_protocol

    try:
        ds_name, dataset = build_from_config(dict(cfg["dataset"]), "dataset")
        protocol = build_protocol(cfg)
    except CatposeError as e:
        raise DatasetError(f"cannot rebuild the dataset from {run_dir}/config.yaml: {e}") from None
    dataset.name = ds_name
    sample = protocol.load(dataset, sample_id)
    T_est = None if row.get("T_est") is None else np.asarray(row["T_est"], float).reshape(4, 4)
    err = None if row.get("status") != "ok" else float(row["err_deg"])
    title = title or f"{run.method} | {sample_id} | {row.get('status')}"
    return plot_registration(
        sample.problem.points_camera,
        sample.problem.template.points,
        T_est,
        sample.gt.T_template_camera,
        out_stem,
        title,
        err,
        pdf,
    )
