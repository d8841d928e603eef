"""Figures of results tables: the values read from both table shapes, the CSV beside the figure,
and the committed figures of the README's tables drawn from the committed tables."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

from catpose.errors import DatasetError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import run_study  # noqa: E402

_script = run_study("tools/table_figure.py")  # cheap: its plotting imports are inside the functions
plot_table, read_table = _script["plot_table"], _script["read_table"]

REPO = Path(__file__).resolve().parents[1]

SUITE = """| method | ycbv: mean / med / @10 / @30 (s) | tyol: mean / med / @10 / @30 (s) |
|---|---|---|
| ours | **11.18** / 1.78 / **0.947** / 0.947 (0.27) n=38 | 179.90 / 179.90 / 0.000 / 0.000 (1.93) n=1 |
| teaser | 137.51 / 158.65 / 0.026 / <u>0.026</u> (0.19, 9 failed) n=38 | 180.00 / 180.00 / 0.000 / 0.000 (0.11, 1 failed) n=1 |
"""

METRICS = """**One template (airplane_0536)**

| Pipeline / Descriptor | Methods | Airplane Mean° ↓ | Airplane Med.° ↓ | Airplane @10 ↑ | Airplane @30 ↑ | Airplane n |
|---|---|---|---|---|---|---|
| - | ICP | 61.909 | **2.950** | 0.559 | 0.618 | 34 |
| Direct match FPFH | FGR | 144.897 | 143.240 | 0.000 | 0.000 | 34 |
|  | RANSAC | 82.463 | 60.640 | 0.265 | 0.471 | 34 |
"""


def test_suite_tables(tmp_path: Path):
    (tmp_path / "t.md").write_text(SUITE)
    title, bars = read_table(tmp_path / "t.md")
    got = [(b.group, b.label, b.acc10, b.acc30, b.mean_deg, b.n) for b in bars]
    assert got == [
        ("ycbv", "ours", 0.947, 0.947, 11.18, 38),
        ("tyol", "ours", 0.0, 0.0, 179.9, 1),
        ("ycbv", "teaser", 0.026, 0.026, 137.51, 38),
        ("tyol", "teaser", 0.0, 0.0, 180.0, 1),
    ]


SUITE_FOUND = """| method | ycbv: mean / med / @10 / found@10 / @30 (s) | ycbv: AR (VSD / MSSD / MSPD) |
|---|---|---|
| ours | **53.00** / 2.22 / **0.711** / 1.000 / 0.711 (0.09) n=38 | **0.793** (0.964 / 0.711 / 0.703) |
| icp | 118.67 / 178.40 / 0.342 / - / 0.352 (1.25) n=38 | 0.543 (0.951 / 0.342 / 0.334) |
"""


def test_suite_tables_with_found_and_ar_columns(tmp_path: Path):
    (tmp_path / "t.md").write_text(SUITE_FOUND)
    _, bars = read_table(tmp_path / "t.md")
    got = [(b.group, b.label, b.acc10, b.acc30, b.mean_deg, b.n) for b in bars]
    assert got == [("ycbv", "ours", 0.711, 0.711, 53.0, 38), ("ycbv", "icp", 0.342, 0.352, 118.67, 38)]


def test_metric_tables_carry_the_pipeline_down(tmp_path: Path):
    (tmp_path / "t.md").write_text(METRICS)
    title, bars = read_table(tmp_path / "t.md")
    assert title == "One template (airplane_0536)"
    assert [(b.group, b.label, b.acc10, b.acc30, b.mean_deg) for b in bars] == [
        ("Airplane", "ICP", 0.559, 0.618, 61.909),
        ("Airplane", "Direct match FPFH FGR", 0.0, 0.0, 144.897),
        ("Airplane", "Direct match FPFH RANSAC", 0.265, 0.471, 82.463),
    ]
    paths = plot_table(tmp_path / "t.md", tmp_path / "fig", pdf=False)
    assert [p.suffix for p in paths] == [".png", ".csv"] and paths[0].read_bytes()[:4] == b"\x89PNG"
    assert pd.read_csv(paths[1])["acc30"].tolist() == [0.618, 0.0, 0.471]


def test_a_file_without_a_table_is_one_line(tmp_path: Path):
    (tmp_path / "t.md").write_text("no table here\n")
    with pytest.raises(DatasetError, match="no Markdown table found"):
        read_table(tmp_path / "t.md")
    (tmp_path / "u.md").write_text("| a | b |\n|---|---|\n| 1 | 2 |\n")
    with pytest.raises(DatasetError, match="no method column"):
        read_table(tmp_path / "u.md")


@pytest.mark.parametrize(
    "table, stem",
    [
        ("report/tables/gt_model_summary.md", "embedded_gt_model"),
        ("real/headline.md", "real"),
        ("clutter/headline.md", "clutter"),
        ("category/paper/one_template_airplane.md", "one_template_airplane"),
    ],
)
def test_committed_figures_show_the_committed_tables(table, stem):
    """results/figures/ holds what `results/make_results.sh figures` draws from the tables the
    README quotes: a table regenerated without its figure fails here."""
    _, bars = read_table(REPO / "results" / table)
    plotted = pd.read_csv(REPO / "results" / "figures" / f"{stem}.csv")
    assert len(plotted) == len(bars)
    for b, row in zip(bars, plotted.itertuples()):
        assert (row.group, row.label) == (b.group, b.label)
        assert (row.acc10, row.acc30, row.mean_deg) == pytest.approx((b.acc10, b.acc30, b.mean_deg), rel=1e-5)
