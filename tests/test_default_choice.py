"""experiments/category_choice/default_choice.py: each (table, method) row set weighs the same, only
rules every row set has are pooled, and the default is the highest mean @10, then the lowest mean
error."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_fixture  # noqa: E402

pytestmark = pytest.mark.experiment

script = study_fixture("experiments/category_choice/default_choice.py")


def _table(rows):
    return pd.DataFrame(rows, columns=["method", "choice", "views", "chosen_acc10", "chosen_mean"])


def test_row_sets_weigh_the_same_and_ties_go_to_the_lower_error(script, tmp_path):
    big = _table([("ICP", "a", 240, 0.9, 10.0), ("ICP", "b", 240, 0.5, 30.0), ("ICP", "c", 240, 0.9, 10.0)])
    small = _table(
        [
            ("ICP", "a", 48, 0.5, 40.0),
            ("ICP", "b", 48, 0.9, 5.0),
            ("Ours", "a", 48, 0.7, 9.0),
            ("Ours", "b", 48, 0.7, 8.0),
        ]
    )
    acc, summary, rules = script["pooled"]({"big": big, "small": small})
    assert rules == ["a", "b"]  # c is missing from two row sets
    assert list(acc["views"]) == [240, 48, 48]
    # @10 (0.9 + 0.5 + 0.7) / 3 each: a tie, broken by the mean error (53 / 3 against 43 / 3)
    assert summary.loc["a", "mean @10"] == pytest.approx(0.7) == summary.loc["b", "mean @10"]
    assert summary.loc["b", "mean error"] == pytest.approx(43.0 / 3)
    assert summary.loc["a", "row sets won"] == 2 and summary.loc["b", "row sets won"] == 2  # the tie counts for both
    out = tmp_path / "t.md"
    assert script["main"]([str(tmp_path / "big.csv"), "--out", str(out)]) == 2  # no such table: one line, exit 2
    big.to_csv(tmp_path / "big.csv", index=False)
    small.to_csv(tmp_path / "small.csv", index=False)
    assert script["main"]([str(tmp_path / "big.csv"), str(tmp_path / "small.csv"), "--out", str(out)]) == 0
    assert "the default takes: b." in out.read_text()
    _table([]).drop(columns="views").to_csv(tmp_path / "bad.csv", index=False)
    assert script["main"]([str(tmp_path / "bad.csv"), "--out", str(out)]) == 2
