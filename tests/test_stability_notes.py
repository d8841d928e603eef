"""Stability notes (experiments/stability/stability.py): the same runs under other code paths,
compared view by view, under ``bench table``'s table."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from catpose.bench.report.runs import load_run
from catpose.errors import DatasetError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_module  # noqa: E402
from test_tables import make_run  # noqa: E402

pytestmark = pytest.mark.experiment
study = study_module("experiments/stability/stability.py")


def _run(root: Path, method: str, errors: dict) -> Path:
    return make_run(root / "toy-gt_model" / method, "seed0-x-abc", errors, {"name": method})


def test_changed_views_and_ranges_are_counted(tmp_path: Path, study):
    own = _run(tmp_path / "own", "icp", {"mug": [2.0, 150.0, 5.0], "can": [1.0]})
    _run(tmp_path / "v1", "icp", {"mug": [2.5, 20.0, 5.0], "can": [1.0]})  # one view flips 150 -> 20
    _run(tmp_path / "v2", "icp", {"mug": [2.0, 150.0, 5.0], "can": [1.0]})  # identical
    s = study.stability([load_run(own)], [tmp_path / "v1", tmp_path / "v2"])
    assert s.n == 4 and s.changed == 1  # the 0.5 deg move is below the 1 deg threshold
    assert s.mean_deg[0] == pytest.approx(158.0 / 4) and min(s.mean_deg) == pytest.approx(28.5 / 4)
    assert s.acc30 == (0.75, 1.0, 0.75)
    lines = study.stability_notes([load_run(own)], ["ICP"], [tmp_path / "v1", tmp_path / "v2"])
    assert lines[1] == "- ICP: 1 of 4 changed; mean 39.50 (7.12-39.50) deg, @10 0.750, @30 0.750 (0.750-1.000)"


def test_a_missing_twin_is_named(tmp_path: Path, study):
    own = _run(tmp_path / "own", "icp", {"mug": [2.0]})
    (tmp_path / "v1").mkdir()
    with pytest.raises(DatasetError, match="has no twin of"):
        study.stability([load_run(own)], [tmp_path / "v1"])


def test_the_table_carries_the_notes_under_it(tmp_path: Path, study):
    own = _run(tmp_path / "own", "icp", {"mug": [2.0, 150.0]})
    _run(tmp_path / "v1", "icp", {"mug": [2.0, 3.0]})
    out = tmp_path / "t.md"
    assert study.main([str(own), "--stability", str(tmp_path / "v1"), "--out", str(out)]) == 0
    text = out.read_text()
    assert text.index("| ICP |") < text.index("Stability under 1 other code path(s)") and "1 of 2 changed" in text
