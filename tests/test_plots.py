"""Figures checked on their data: the values read back from the figure's artists and from the CSV
written beside it, against values counted here from the input rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from catpose.bench.report import plots
from catpose.bench.scoring.curves import scored_errors
from catpose.geometry import axis_angle_to_R, make_T

# Errors in degrees (None: failed). "ICP" is near zero everywhere: it must stay visible.
ERRORS = {
    "ICP": {"bottle": [0.02, 0.05, 0.03], "chair": [0.2, None, 0.1]},
    "Ours": {"bottle": [1.0, 12.0, 0.5], "chair": [45.0, 3.0, 100.0, 7.5]},
}
RUNTIMES = {"ICP": [0.1, 0.2, 0.4, 0.3, 0.25, 0.15], "Ours": [1.0, 2.0, 0.5, 3.0, 1.5, 2.5, 0.75]}


def _units(errors: dict[str, list[float | None]], runtimes: list[float]) -> pd.DataFrame:
    rows = [
        {"category": c, "status": "ok" if e is not None else "failed", "err_deg": e}
        for c, es in errors.items()
        for e in es
    ]
    return pd.DataFrame(rows).assign(runtime_s=runtimes[: len(rows)])


@pytest.fixture()
def units() -> dict[str, pd.DataFrame]:
    return {m: _units(e, RUNTIMES[m]) for m, e in ERRORS.items()}


@pytest.fixture()
def captured(monkeypatch) -> list:
    """The figures handed to ``plots.save``, kept open so their artists can be read back."""
    figs: list = []

    def keep(fig, out_stem, pdf=True, dpi=150):
        fig.canvas.draw()
        figs.append(fig)
        paths = [Path(out_stem).with_suffix(".png")]
        fig.savefig(paths[0], dpi=50)
        return paths

    monkeypatch.setattr(plots, "save", keep)
    yield figs
    import matplotlib.pyplot as plt

    for fig in figs:
        plt.close(fig)


def _scored(errs: list[float | None]) -> list[float]:
    return [180.0 if e is None else float(e) for e in errs]


def test_scored_errors_counts_failures_as_180():
    e = scored_errors(_units({"a": [5.0, None, 20.0]}, [1, 1, 1]))
    assert e.tolist() == [5.0, 180.0, 20.0]


def test_cdf_points_match_counting(units, captured, tmp_path: Path):
    paths = plots.plot_error_cdf(units, tmp_path / "cdf")
    csv = pd.read_csv(paths[-1])
    fig = captured[0]
    axes = {ax.get_title().split(" (")[0]: ax for ax in fig.axes if ax.get_title()}
    assert set(axes) == {"bottle", "chair"}
    for method, by_cat in ERRORS.items():
        for cat, errs in by_cat.items():
            scored = _scored(errs)
            expected_x = sorted(scored)
            expected_y = [sum(s <= x for s in scored) / len(scored) for x in expected_x]  # counted, not arange
            rows = csv[(csv["method"] == method) & (csv["category"] == cat)]
            assert rows["error_deg"].tolist() == pytest.approx(expected_x, rel=1e-5)
            assert rows["fraction"].tolist() == pytest.approx(expected_y, rel=1e-5)
            assert set(rows["n"]) == {len(scored)}
            # The drawn step line: a start at the floor, the points, the end at 180.
            (line,) = [ln for ln in axes[cat].get_lines() if ln.get_label() == method]
            x, y = line.get_xdata()[1:-1], line.get_ydata()[1:-1]
            assert x.tolist() == pytest.approx(expected_x)  # all errors are above the axis start here
            assert y.tolist() == pytest.approx(expected_y)
    # Log axis: the near-zero method's curve is spread over the panel, not squeezed at 0.
    ax = axes["bottle"]
    assert ax.get_xscale() == "log" and ax.get_xlim()[0] == pytest.approx(0.01)
    lo, hi = np.log10(ax.get_xlim())
    icp_x = [ln for ln in ax.get_lines() if ln.get_label() == "ICP"][0].get_xdata()[1:-1]
    assert (np.log10(icp_x.max()) - np.log10(icp_x.min())) / (hi - lo) > 0.05
    legend_labels = {t.get_text() for a in fig.axes if a.get_legend() for t in a.get_legend().get_texts()}
    legend_labels |= {t.get_text() for lg in fig.legends for t in lg.get_texts()}
    assert legend_labels == set(ERRORS)


def test_cdf_floor():
    assert plots.cdf_floor(np.array([0.5, 3.0, 180.0])) == pytest.approx(0.01)
    assert plots.cdf_floor(np.array([0.0, 0.004, 3.0])) == pytest.approx(0.001)  # zero has no log; 0.004 sets it
    assert plots.cdf_floor(np.array([1e-9, 1.0])) == pytest.approx(plots.CDF_MIN_FLOOR_DEG)


def test_accuracy_bars_match_counting(units, captured, tmp_path: Path):
    thresholds = (1.0, 10.0, 30.0)
    paths = plots.plot_accuracy(units, tmp_path / "acc", thresholds=thresholds)
    csv = pd.read_csv(paths[-1])
    ax = captured[0].axes[0]
    for k, method in enumerate(ERRORS):
        scored = [s for errs in ERRORS[method].values() for s in _scored(errs)]
        expected = [sum(s <= t for s in scored) / len(scored) for t in thresholds]
        rows = csv[csv["method"] == method]
        assert rows["threshold_deg"].tolist() == list(thresholds)
        assert rows["accuracy"].tolist() == pytest.approx(expected, rel=1e-5)
        heights = [bar.get_height() for bar in ax.containers[k]]
        assert heights == pytest.approx(expected)
        assert ax.containers[k].get_label() == method
    # Ours: 0.5 and 1.0 of 7 are <= 1 deg
    assert csv[(csv["method"] == "Ours") & (csv["threshold_deg"] == 1.0)]["accuracy"].item() == pytest.approx(2 / 7)


def test_files_written(units, tmp_path: Path):
    for fn, name in ((plots.plot_error_cdf, "cdf"), (plots.plot_accuracy, "acc")):
        paths = fn(units, tmp_path / name)
        assert [p.suffix for p in paths] == [".png", ".pdf", ".csv"]
        assert paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert paths[1].read_bytes()[:4] == b"%PDF"
    assert [p.suffix for p in plots.plot_accuracy(units, tmp_path / "acc2", pdf=False)] == [".png", ".csv"]


def test_registration_picture_places_points(captured, tmp_path: Path):
    """The estimate panel shows the input carried by T_est: with T_est = T_gt it lies on the template."""
    rng = np.random.default_rng(0)
    template = rng.normal(size=(500, 3))
    template /= np.linalg.norm(template, axis=1, keepdims=True)
    T_gt = make_T(axis_angle_to_R(np.array([0, 0, 1.0]), 0.5), [0, 0, -3])
    points_camera = (template[:200] - T_gt[:3, 3]) @ T_gt[:3, :3]  # inv(T_gt) applied
    plots.plot_registration(points_camera, template, T_gt, T_gt, tmp_path / "reg", "toy", 0.0)
    fig = captured[0]
    assert len(fig.axes) == 2 and fig.axes[0].get_title() == "estimate (0.0 deg)"
    drawn = np.column_stack(fig.axes[0].collections[1]._offsets3d)  # the input, in the template frame
    np.testing.assert_allclose(drawn, template[:200], atol=1e-9)


def test_given_colours_are_used(units, captured, tmp_path: Path):
    """The report gives each method one colour across its figures."""
    from matplotlib.colors import to_rgba

    plots.plot_error_cdf(units, tmp_path / "cdf", colors={"Ours": "red"})
    plots.plot_accuracy(units, tmp_path / "acc", colors={"Ours": "red"})
    lines = [ln for ax in captured[0].axes for ln in ax.get_lines() if ln.get_label() == "Ours"]
    assert lines and all(to_rgba(ln.get_color()) == to_rgba("red") for ln in lines)
    ours_bars = [c for c in captured[1].axes[0].containers if c.get_label() == "Ours"][0]
    assert all(b.get_facecolor() == to_rgba("red") for b in ours_bars)


def test_the_same_figure_is_the_same_bytes(tmp_path: Path, monkeypatch):
    """No creation date in the PDF (nor anything else that changes between runs), so regenerated
    results/ figures are byte for byte the committed ones."""
    from catpose.bench.report import plots

    outs = []
    for k in range(2):
        monkeypatch.setenv("SOURCE_DATE_EPOCH", str(1_700_000_000 + 86_400 * k))  # another day's run
        fig, ax = plots.pyplot().subplots()
        ax.plot([0, 1, 2], [2, 0, 1])
        outs.append(plots.save(fig, tmp_path / f"f{k}"))
    for a, b in zip(*outs):
        assert a.read_bytes() == b.read_bytes(), a.suffix
