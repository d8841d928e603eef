"""Figures from run directories (matplotlib, Agg backend; each figure as PNG and PDF).

- :func:`plot_error_cdf`: cumulative distribution of the scored error per method, one panel
  per category (a point (x, y): a fraction y of the samples has error <= x degrees).
- :func:`plot_accuracy`: accuracy (error <= threshold) against the threshold, all categories
  pooled, per method.
- :func:`plot_runtime`: per-registration runtime per method (box plot, log scale).
- :func:`plot_registration`: a qualitative picture of one registration: the observed points
  carried into the template frame by the estimate, over the template, next to the same with the
  ground truth. :func:`plot_sample_from_run` rebuilds the sample from the run's ``config.yaml``
  (dataset + protocol instantiated with Hydra), since the run stores no points.

Inputs are per-method tables of scoring units (``{label: DataFrame}``, columns ``category``,
``status``, ``err_deg``) as :func:`catpose.bench.tables.scored_units` returns them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

import numpy as np

from catpose.bench.metrics import FAILED_ERROR_DEG


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def save(fig, out_stem: str | Path) -> list[Path]:
    """Write ``<out_stem>.png`` (150 dpi) and ``<out_stem>.pdf``; close the figure; return both paths."""
    out_stem = Path(out_stem)
    out_stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [out_stem.with_suffix(".png"), out_stem.with_suffix(".pdf")]
    fig.savefig(paths[0], dpi=150, bbox_inches="tight")
    fig.savefig(paths[1], bbox_inches="tight")
    _plt().close(fig)
    return paths


def scored_errors(units) -> np.ndarray:
    """Errors (degrees) of scoring units, failed ones as 180."""
    import pandas as pd

    err = pd.to_numeric(units["err_deg"], errors="coerce").to_numpy(float)
    failed = (units["status"] != "ok").to_numpy()
    return np.where(failed | np.isnan(err), FAILED_ERROR_DEG, err)


def plot_error_cdf(units_by_method: Mapping[str, object], out_stem: str | Path, title: str = "") -> list[Path]:
    """Cumulative distribution of the error per method, one panel per category."""
    plt = _plt()
    categories = sorted({c for u in units_by_method.values() for c in u["category"].astype(str)})
    n = max(len(categories), 1)
    cols = min(n, 4)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.0 * rows), squeeze=False, sharey=True)
    for ax, cat in zip(axes.ravel(), categories):
        for m, (label, units) in enumerate(units_by_method.items()):
            u = units[units["category"].astype(str) == cat]
            if len(u) == 0:
                continue
            e = np.sort(scored_errors(u))
            y = np.arange(1, len(e) + 1) / len(e)
            ax.step(np.concatenate([[0], e]), np.concatenate([[0], y]), where="post", color=f"C{m % 10}",
                    label=f"{label} (n={len(e)})")  # one colour per method across panels
        ax.set_title(cat)
        ax.text(0.98, 0.04, "n=" + ", ".join(str(int((units["category"].astype(str) == cat).sum()))
                                              for units in units_by_method.values()),
                transform=ax.transAxes, ha="right", fontsize=6, color="grey")
        ax.set_xlim(0, 180)
        ax.set_ylim(0, 1.02)
        ax.set_xticks([0, 30, 60, 90, 120, 150, 180])
        ax.grid(alpha=0.3)
        ax.set_xlabel("error [deg]")
    for ax in axes[:, 0]:
        ax.set_ylabel("fraction of samples <= error")
    for ax in axes.ravel()[len(categories):]:
        ax.axis("off")
    handles: dict[str, object] = {}
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab.rsplit(" (n=", 1)[0], h)
    fig.suptitle(title or "Cumulative distribution of the error (rotation; main axis for symmetric objects)")
    fig.tight_layout()
    fig.legend(list(handles.values()), list(handles), loc="lower center", fontsize=7,
               ncol=min(len(handles), 4), bbox_to_anchor=(0.5, -0.02 - 0.04 * (len(handles) // 4)))
    return save(fig, out_stem)


def plot_accuracy(units_by_method: Mapping[str, object], out_stem: str | Path, max_threshold_deg: float = 60.0,
                  title: str = "") -> list[Path]:
    """Accuracy (fraction with error <= threshold) against the threshold, categories pooled."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.0, 3.6))
    th = np.linspace(0, max_threshold_deg, 241)
    for m, (label, units) in enumerate(units_by_method.items()):
        e = scored_errors(units)
        if len(e):
            ax.plot(th, [(e <= t).mean() for t in th], color=f"C{m % 10}", label=f"{label} (n={len(e)})")
    for t in (10, 30):
        ax.axvline(t, color="grey", lw=0.8, ls="--")
    ax.set_xlim(0, max_threshold_deg)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("threshold [deg]")
    ax.set_ylabel("accuracy")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(title or "Accuracy against threshold (all categories)")
    fig.tight_layout()
    return save(fig, out_stem)


def plot_runtime(samples_by_method: Mapping[str, object], out_stem: str | Path, title: str = "") -> list[Path]:
    """Box plot of per-registration runtime (seconds, log scale) per method, from per-sample rows."""
    import pandas as pd

    plt = _plt()
    labels, data = [], []
    for label, s in samples_by_method.items():
        r = pd.to_numeric(s["runtime_s"], errors="coerce").to_numpy(float)
        r = r[np.isfinite(r) & (r > 0)]
        if len(r):
            labels.append(f"{label}\nmedian {np.median(r):.3g} s")
            data.append(r)
    fig, ax = plt.subplots(figsize=(max(3.0, 1.4 * len(labels) + 1), 3.6))
    if data:
        ax.boxplot(data, showfliers=True)
        ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=7)
        ax.set_yscale("log")
    ax.set_ylabel("seconds per registration")
    ax.grid(alpha=0.3, axis="y")
    ax.set_title(title or "Runtime per registration")
    fig.tight_layout()
    return save(fig, out_stem)


def _scatter(ax, points: np.ndarray, color: str, size: float, label: str, max_points: int = 3000) -> None:
    if len(points) > max_points:
        points = points[np.linspace(0, len(points) - 1, max_points).astype(int)]
    ax.scatter(points[:, 0], points[:, 1], points[:, 2], s=size, c=color, label=label, depthshade=False)


def plot_registration(points_camera: np.ndarray, template_points: np.ndarray, T_est: np.ndarray | None,
                      T_gt: np.ndarray | None, out_stem: str | Path, title: str = "",
                      err_deg: float | None = None) -> list[Path]:
    """The input (orange) carried into the template frame over the template (blue-grey).

    Args:
        points_camera: (N, 3) observed points, camera frame.
        template_points: (M, 3) template points, template frame.
        T_est, T_gt: (4, 4) estimated / true ``T_template_camera`` (either may be None).
    """
    from catpose.geometry import transform_points

    plt = _plt()
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
    return save(fig, out_stem)


def plot_sample_from_run(run_dir: str | Path, sample_id: str, out_stem: str | Path) -> list[Path]:
    """Re-load ``sample_id`` from the run's config (dataset + protocol) and plot its registration.

    Raises :class:`~catpose.errors.CatposeError` when the dataset cannot be rebuilt here.
    """
    from catpose.bench.tables import load_run
    from catpose.errors import CatposeError, ConfigError, DatasetError

    run = load_run(run_dir)
    rows = run.samples[run.samples["sample_id"] == sample_id]
    if len(rows) == 0:
        raise DatasetError(f"sample {sample_id!r} is not in {run_dir}/samples.jsonl")
    row = rows.iloc[-1]
    cfg = run.config
    if not isinstance(cfg.get("dataset"), dict) or not isinstance(cfg.get("protocol"), dict):
        raise ConfigError(f"{run_dir}/config.yaml has no dataset/protocol to re-load samples from")
    from catpose.bench.build import build_from_config

    try:
        ds_name, dataset = build_from_config(dict(cfg["dataset"]), "dataset")
        protocol = build_from_config(dict(cfg["protocol"]), "protocol")[1]
    except CatposeError as e:
        raise DatasetError(f"cannot rebuild the dataset from {run_dir}/config.yaml: {e}") from None
    dataset.name = ds_name
    sample = protocol.load(dataset, sample_id)
    T_est = None if row.get("T_est") is None else np.asarray(row["T_est"], float).reshape(4, 4)
    err = None if row.get("status") != "ok" else float(row["err_deg"])
    title = f"{run.method} | {sample_id} | {row.get('status')}"
    return plot_registration(sample.problem.points_camera, sample.problem.template.points, T_est,
                             sample.gt.T_template_camera, out_stem, title, err)
