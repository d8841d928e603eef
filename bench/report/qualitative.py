"""Qualitative figures: one registration drawn in 3D (matplotlib, Agg backend).

- :func:`plot_registration`: the observed points carried into the template frame by the
  estimate, over the template, next to the same with the ground truth;
- :func:`plot_sample_from_run`: the same for one sample of a run, rebuilt from the run's
  ``config.yaml`` (dataset + protocol built by :func:`catpose.bench.run.build.build_from_config`),
  since the run stores no points.

The aggregate figures (CDF, accuracy) are :mod:`catpose.bench.report.plots`'.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from catpose.bench.report import plots


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

    plt = plots.pyplot()
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
    return plots.save(fig, out_stem, pdf, dpi=110)


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
