"""Metrics against hand-computed values."""

import math

import numpy as np
import pandas as pd
import pytest

from catpose.bench.scoring.metrics import (
    FAILED_ERROR_DEG,
    accuracy,
    axis_error_deg,
    rotation_error_deg,
    runtime_stats,
    sample_errors,
    summarize,
    translation_error,
)
from catpose.geometry import axis_angle_to_R, make_T, random_rotation


def Rz(deg):
    return axis_angle_to_R(np.array([0, 0, 1.0]), math.radians(deg))


def Rx(deg):
    return axis_angle_to_R(np.array([1.0, 0, 0]), math.radians(deg))


def test_rotation_error_hand_values():
    assert rotation_error_deg(np.eye(3), np.eye(3)) == pytest.approx(0.0, abs=1e-6)
    assert rotation_error_deg(Rz(30), np.eye(3)) == pytest.approx(30.0)
    assert rotation_error_deg(Rz(30), Rz(-15)) == pytest.approx(45.0)
    assert rotation_error_deg(Rx(180), np.eye(3)) == pytest.approx(180.0)
    # a 90 degree turn about x then 90 about z: trace = 0 -> arccos(-1/2) = 120 degrees
    assert rotation_error_deg(Rz(90) @ Rx(90), np.eye(3)) == pytest.approx(120.0)


def test_rotation_error_is_symmetric_and_invariant():
    rng = np.random.default_rng(0)
    A, B, C = (random_rotation(rng) for _ in range(3))
    assert rotation_error_deg(A, B) == pytest.approx(rotation_error_deg(B, A))
    assert rotation_error_deg(C @ A, C @ B) == pytest.approx(rotation_error_deg(A, B))


def test_translation_error_hand_value():
    assert translation_error(np.array([1.0, 2.0, 2.0]), np.zeros(3)) == pytest.approx(3.0)


def test_axis_error_ignores_rotation_about_the_axis():
    z = np.array([0, 0, 1.0])
    assert axis_error_deg(Rz(77), np.eye(3), z) == pytest.approx(0.0, abs=1e-6)
    assert axis_error_deg(Rx(20) @ Rz(77), np.eye(3), z) == pytest.approx(20.0)
    assert axis_error_deg(Rx(180), np.eye(3), z) == pytest.approx(180.0)


def test_sample_errors_picks_axis_error_for_symmetric():
    T_est, T_gt = make_T(Rz(40), [0.0, 0.0, 0.5]), make_T(np.eye(3), np.zeros(3))
    e = sample_errors(T_est, T_gt, np.array([0, 0, 1.0]))
    assert e["rot_err_deg"] == pytest.approx(40.0) and e["err_deg"] == pytest.approx(0.0, abs=1e-6)
    assert e["trans_err"] == pytest.approx(0.5)
    e = sample_errors(T_est, T_gt, None)
    assert e["err_deg"] == pytest.approx(40.0) and math.isnan(e["axis_err_deg"])


def test_symmetric_translation_error_ignores_the_spin_about_the_axis():
    # camera 3 units in front of a can: a spin about z moves the camera in the template frame
    # (t changes) but not the can's position in the camera frame
    R_gt = np.array([[0.0, -1, 0], [0, 0, -1], [1, 0, 0]]).T  # any rotation
    T_gt = make_T(R_gt, [3.0, 0.0, 0.0])
    spin = Rz(90)
    T_est = make_T(spin @ R_gt, spin @ np.array([3.0, 0.0, 0.0]))
    e = sample_errors(T_est, T_gt, np.array([0, 0, 1.0]))
    assert e["err_deg"] == pytest.approx(0.0, abs=1e-6) and e["trans_err"] == pytest.approx(0.0, abs=1e-9)
    assert sample_errors(T_est, T_gt, None)["trans_err"] == pytest.approx(3 * math.sqrt(2))


def test_accuracy_and_runtime_stats():
    assert accuracy([1, 10, 11, 30, 31], 10) == pytest.approx(0.4)
    assert accuracy([1, 10, 11, 30, 31], 30) == pytest.approx(0.8)
    r = runtime_stats([1.0, 2.0, 3.0, float("nan")])
    assert r["mean_s"] == pytest.approx(2.0) and r["median_s"] == pytest.approx(2.0) and r["total_s"] == 6.0


def test_summarize_counts_failed_as_180_and_reports_them():
    df = pd.DataFrame(
        {
            "category": ["a", "a", "a", "b"],
            "status": ["ok", "ok", "failed", "ok"],
            "err_deg": [5.0, 20.0, None, 40.0],
            "trans_err": [0.1, 0.3, None, 0.5],
            "runtime_s": [1.0, 3.0, None, 2.0],
        }
    )
    s = summarize(df).set_index("category")
    assert s.loc["a", "n"] == 3 and s.loc["a", "failed"] == 1
    assert s.loc["a", "mean_err_deg"] == pytest.approx((5 + 20 + FAILED_ERROR_DEG) / 3)
    assert s.loc["a", "median_err_deg"] == pytest.approx(20.0)
    assert s.loc["a", "acc10"] == pytest.approx(1 / 3) and s.loc["a", "acc30"] == pytest.approx(2 / 3)
    assert s.loc["a", "mean_trans_err"] == pytest.approx(0.2)  # failed rows have no translation
    assert s.loc["a", "median_runtime_s"] == pytest.approx(2.0)
    assert s.loc["all", "n"] == 4 and s.loc["all", "mean_err_deg"] == pytest.approx((5 + 20 + 180 + 40) / 4)


def test_discrete_symmetry_takes_the_closest_equivalent_pose():
    T_gt = make_T(Rx(30), [0.1, 0.2, 3.0])
    flip = make_T(Rz(180), np.zeros(3))  # a basket with a 2-fold symmetry about z
    T_est = flip @ T_gt
    assert sample_errors(T_est, T_gt)["err_deg"] == pytest.approx(180.0)
    e = sample_errors(T_est, T_gt, None, [flip])
    assert e["err_deg"] == pytest.approx(0.0, abs=1e-6) and e["trans_err"] == pytest.approx(0.0, abs=1e-9)
    e = sample_errors(make_T(Rz(10), np.zeros(3)) @ T_est, T_gt, None, [flip])
    assert e["err_deg"] == pytest.approx(10.0)
