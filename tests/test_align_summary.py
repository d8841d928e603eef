"""experiments/alignment/align_summary.py: one Markdown row per comparison ``align.py
--compare`` wrote, read back as it was written; a missing file is one line and exit 2."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments" / "alignment"))
import align_check  # noqa: E402  (the study's scripts)
from alignment_estimate import write_alignment_table  # noqa: E402

from catpose.geometry import axis_angle_to_R  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_module  # noqa: E402

pytestmark = pytest.mark.experiment

summary = study_module("experiments/alignment/align_summary.py")


def test_a_comparison_read_back_and_its_row(summary, tmp_path, capsys):
    yaw = [axis_angle_to_R(np.array([0, 0, 1.0]), np.deg2rad(90 * k)) for k in range(4)]
    write_alignment_table(
        tmp_path / "v.csv",
        [{"category": "c", "instance_id": i, "R": yaw[k]} for i, k in (("a", 0), ("b", 1), ("c", 2))],
    )
    write_alignment_table(
        tmp_path / "e.csv",
        [
            {"category": "c", "instance_id": i, "R": yaw[k], "confidence": c}
            for i, k, c in (("a", 0, 0.4), ("b", 3, 0.05), ("c", 2, 0.3))
        ],
    )
    res = align_check.compare_tables(tmp_path / "e.csv", tmp_path / "v.csv", "c")
    path = align_check.write_comparison(tmp_path / "e_vs_verified.csv", res)
    back = summary.read_comparison(path)
    assert back["agree"] == 2 and back["n"] == 3 and back["roc"]["separates"]
    assert summary.main([f"x={path}", "--out", str(tmp_path / "s.md")]) == 0
    assert "| x | 2/3 | 1.000 | yes | 0.300 | 0.050 | b |" in (tmp_path / "s.md").read_text()
    assert summary.main(["x=missing.csv"]) == 2
    assert "is not NAME=<existing comparison csv>" in capsys.readouterr().err
