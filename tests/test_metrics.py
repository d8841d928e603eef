"""Metrics against hand-computed values."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from catpose.bench.scoring.metrics import (
    FAILED_ERROR_DEG,
    accuracy,
    axis_error_deg,
    rotation_error_deg,
    sample_errors,
    summarize,
    translation_error,
)
from catpose.geometry import axis_angle_to_R, make_T


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
    A, B, C = (Rotation.random(random_state=rng).as_matrix() for _ in range(3))
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


def test_accuracy():
    assert accuracy([1, 10, 11, 30, 31], 10) == pytest.approx(0.4)
    assert accuracy([1, 10, 11, 30, 31], 30) == pytest.approx(0.8)


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


# --------------------------------------------------------------- conditioning and portable bits


def _turn(axis, deg):
    return axis_angle_to_R(np.asarray(axis, float) / np.linalg.norm(axis), math.radians(deg))


@pytest.mark.parametrize("deg", [0.0, 1e-7, 1e-4, 0.06, 10.0, 90.0, 179.9, 180.0 - 1e-4, 180.0 - 1e-7, 180.0])
def test_rotation_error_matches_scipy_near_0_and_180_degrees(deg):
    """Against scipy's quaternion angle (an independent reference), to 1e-9 degrees at every angle:
    ``arccos`` of the cosine would be 1e-7 deg off at 1e-7 deg (the cosine rounds to 1)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(int(deg * 1000) % 2**32)
    R_gt = Rotation.random(random_state=rng).as_matrix()
    R_est = R_gt @ _turn(rng.normal(size=3), deg)
    reference = math.degrees(Rotation.from_matrix(R_gt.T @ R_est).magnitude())
    assert rotation_error_deg(R_est, R_gt) == pytest.approx(reference, abs=1e-9)
    assert rotation_error_deg(R_est, R_gt) == pytest.approx(deg, abs=1e-9)


@pytest.mark.parametrize("deg", [1e-7, 0.5, 45.0, 179.5, 180.0 - 1e-7])
def test_axis_error_is_exact_near_0_and_180_degrees(deg):
    """A tilt of the axis by a known angle (the turn about a line perpendicular to it) is measured
    to 1e-9 degrees, also against scipy's angle of the turn taking one axis to the other."""
    from scipy.spatial.transform import Rotation

    axis = np.array([0.3, -0.5, 0.8])
    R_gt = Rotation.random(random_state=np.random.default_rng(3)).as_matrix()
    R_est = _turn(np.cross(axis, [1.0, 0, 0]), deg) @ R_gt  # tilts the template's axis by deg
    assert axis_error_deg(R_est, R_gt, axis) == pytest.approx(deg, abs=1e-9)
    u, v = R_est.T @ axis, R_gt.T @ axis
    turn, _ = Rotation.align_vectors(u[None], v[None])
    assert axis_error_deg(R_est, R_gt, axis) == pytest.approx(math.degrees(turn.magnitude()), abs=1e-6)


def test_batched_errors_are_the_per_sample_errors():
    from catpose.bench.scoring.metrics import pose_errors_deg

    rng = np.random.default_rng(7)
    T_gt = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3))
    T_est = np.stack(
        [make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3)) for _ in range(6)] + [T_gt]
    )
    flip = make_T(Rx(180), np.zeros(3))
    for axis, syms in ((None, ()), (np.array([0, 0, 2.0]), ()), (None, (flip,))):
        batch = pose_errors_deg(T_est, T_gt, axis, syms)
        single = [sample_errors(T, T_gt, axis, syms)["err_deg"] for T in T_est]
        assert batch.tolist() == single


ERRORS_SCRIPT = r"""
import json, math
import numpy as np
from catpose.bench.run.environment import numpy_blas_kernel
from catpose.bench.scoring.metrics import pose_errors_deg, sample_errors
from catpose.geometry import axis_angle_to_R, make_T, matmul3, unit3
from scipy.spatial.transform import Rotation
rng = np.random.default_rng(11)
T_gt = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3))
T_est = []
for deg in (1e-6, 0.03, 7.0, 120.0, 179.99, 180.0 - 1e-6, 180.0):
    axis = rng.normal(size=3)
    R = matmul3(T_gt[:3, :3], axis_angle_to_R(unit3(axis), math.radians(deg)))  # no BLAS: the same input everywhere
    T_est.append(make_T(R, T_gt[:3, 3] + rng.normal(size=3) * 0.01))
flip = make_T(axis_angle_to_R(np.array([1.0, 0, 0]), math.pi), np.zeros(3))
out = {"kernel": numpy_blas_kernel()}
for name, axis, syms in (("plain", None, ()), ("axis", np.array([0.1, 0.2, 0.97]), ()), ("sym", None, (flip,))):
    out[name] = [sample_errors(T, T_gt, axis, syms) for T in T_est]
    out[name + "_batch"] = pose_errors_deg(np.stack(T_est), T_gt, axis, syms).tolist()
print(json.dumps(out))
"""


def test_errors_are_the_same_bits_under_every_code_path_of_this_cpu():
    """The scorer's errors of estimates near 0 and 180 degrees (plain, about a symmetry axis, with a
    discrete symmetry) are bit for bit the same under each OpenBLAS kernel and NumPy dispatch
    level, so a table recomputed from stored poses does not depend on the machine."""
    import json
    import sys
    from pathlib import Path

    from catpose.bench.run.environment import numeric_variants

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _code_paths import last_line

    variants = {k: v for k, v in numeric_variants().items() if k != "torch-default"}
    if not variants:
        pytest.skip("needs an x86-64 CPU with AVX2 to run other OpenBLAS kernels")
    outs = {}
    for name, env in variants.items():
        outs[name] = json.loads(last_line(ERRORS_SCRIPT, env, timeout=300))
        if "OPENBLAS_CORETYPE" in env:
            assert outs[name]["kernel"] == env["OPENBLAS_CORETYPE"]
    first = next(iter(outs))
    for name, out in outs.items():
        for key in ("plain", "axis", "sym", "plain_batch", "axis_batch", "sym_batch"):
            assert out[key] == outs[first][key], f"{key}: {first} vs {name}"


def test_an_annotation_orthonormal_to_1e_6_does_not_move_a_small_error():
    """BOP stores rotations to a few decimals (TYO-L's are orthonormal to 4e-6): the angle stays at
    the angle between the nearest rotations (SVD), where arccos of the trace is far off."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(5)
    R_true = Rotation.random(random_state=rng).as_matrix()
    R_gt = R_true @ np.diag([1 + 2.2e-6, 1 + 1.5e-6, 1 + 0.5e-6])  # TYO-L's frame: singular values 1 + 2e-6
    R_est = R_true @ _turn(rng.normal(size=3), 0.9)

    U, _, Vt = np.linalg.svd(R_gt)
    nearest = math.degrees(Rotation.from_matrix((U @ Vt).T @ R_est).magnitude())
    trace = math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(R_gt.T @ R_est) - 1) / 2))))
    assert abs(rotation_error_deg(R_est, R_gt) - nearest) < 1e-4
    assert abs(trace - nearest) > 5e-3  # what the definition's arccos reports: 0.008 deg at 0.9 deg
