"""How an estimated alignment table agrees with a verified one (``align.py --compare``,
``experiments/alignment/align_check.py``): up to one common rotation, and the ROC of the confidence."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments" / "alignment"))
import align_check  # noqa: E402  (the study's scripts)
from alignment_estimate import write_alignment_table  # noqa: E402

from catpose.geometry import axis_angle_to_R  # noqa: E402

pytestmark = pytest.mark.experiment


def test_alignment_agreement_is_up_to_one_common_rotation_and_roc_separates():
    yaw = [axis_angle_to_R(np.array([0, 0, 1.0]), np.deg2rad(90 * k)) for k in range(4)]
    verified = {"a": yaw[0], "b": yaw[1], "c": yaw[2], "d": yaw[3]}
    G = yaw[1]  # the estimate lives in a frame turned by 90 deg, and gets "d" wrong
    est = {"a": G @ yaw[0], "b": G @ yaw[1], "c": G @ yaw[2], "d": G @ yaw[1]}
    offset, ok = align_check.agreement(est, verified)
    np.testing.assert_allclose(offset, G, atol=1e-12)
    assert ok == {"a": True, "b": True, "c": True, "d": False}
    r = align_check.roc([0.5, 0.4, 0.3, 0.1], [True, True, True, False])
    assert r["separates"] and r["auc"] == 1.0
    r = align_check.roc([0.5, 0.2, 0.3, 0.25], [True, True, True, False])
    assert not r["separates"] and r["auc"] == pytest.approx(2 / 3)
    assert align_check.roc([0.5], [True])["separates"]


def test_compare_tables_and_summary_line(tmp_path):
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
    assert res["agree"] == 2 and res["roc"]["separates"]
    path = align_check.write_comparison(tmp_path / "e_vs_verified.csv", res)
    lines = path.read_text().splitlines()
    assert lines[0] == "instance_id,agrees,confidence,yaw_deg,flip,verified_yaw_deg,verified_flip"
    assert [ln.split(",")[:3] for ln in lines[1:]] == [
        ["a", "true", "0.4"],
        ["b", "false", "0.05"],
        ["c", "true", "0.3"],
    ]
    assert "agree 2/3" in align_check.summary_line(res)
