"""Bad input to the shared types gives one clear line (InvalidInputError), never a deep traceback."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from catpose.errors import CatposeError, InvalidInputError
from catpose.types import RegistrationProblem, RegistrationResult, Template, validate_cloud


def cloud(n=100, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p, p / np.linalg.norm(p, axis=1, keepdims=True)


@pytest.mark.parametrize(
    "points, normals, needle",
    [
        (np.zeros((0, 3)), None, "has no points"),
        (np.ones((50, 3)), None, "all 50 points are equal"),
        (np.outer(np.arange(50.0), [1, 2, 3]), None, "lie on one line"),
        (np.where(np.arange(300).reshape(100, 3) == 7, np.nan, 1.0) + cloud()[0], None, "NaN or inf"),
        (cloud()[0], np.where(np.arange(300).reshape(100, 3) == 7, np.nan, 1.0), "normals has 1 rows with NaN"),
        (cloud()[0], np.zeros((100, 3)), "zero-length normals"),
        (cloud()[0], cloud(50)[1], "normals have shape (50, 3)"),
        (np.zeros((10, 2)), None, "expected (N, 3)"),
        (cloud(5)[0], None, "has 5 points; at least 10"),
    ],
)
def test_bad_clouds(points, normals, needle):
    with pytest.raises(InvalidInputError) as e:
        validate_cloud("input cloud", points, normals)
    assert needle in str(e.value) and "input cloud" in str(e.value) and "\n" not in str(e.value)


def test_problem_validates_and_normalises():
    p, n = cloud()
    t = Template("t", "c", p, n)
    prob = RegistrationProblem("s", "c", p, n * 2.0, np.array([0.0, 0.0, 5.0]), t)
    assert np.allclose(np.linalg.norm(prob.normals_camera, axis=1), 1.0)
    assert np.allclose(prob.ground_normal_camera, [0, 0, 1])
    with pytest.raises(CatposeError, match="sample s: ground normal"):
        RegistrationProblem("s", "c", p, n, np.array([np.nan, 0.0, 1.0]), t)
    with pytest.raises(CatposeError, match="sample s: observed cloud has no points"):
        RegistrationProblem("s", "c", p[:0], n[:0], np.array([0.0, 0.0, 1.0]), t)


def test_result_is_frozen():
    r = RegistrationResult(T_template_camera=np.eye(4))
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'score'"):
        r.score = 1.0  # frozen
