"""method=ppf: OpenCV's point pair features (catpose.methods.ppf), its frames and its cache.

Skips where OpenCV's contrib build (the extra ``ppf``) is not installed, except the test that the
method then says how to install it. Settings are coarse (model_sampling 0.08) so that training
takes well under a second.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from catpose.errors import ConfigError
from catpose.geometry import apply_R, invert_T
from catpose.types import RegistrationProblem, Template

COARSE = dict(model_sampling=0.08, scene_sampling=0.05, top_k=2)


def _rendered_chair(seed: int) -> tuple[RegistrationProblem, np.ndarray, float]:
    """A procedural chair rendered at a known pose, against its own complete model: (problem,
    true ``T_template_camera``, the template's diameter)."""
    from catpose.datasets.meshio import sample_outer_surface
    from catpose.datasets.render import PinholeCamera, depth_to_points, estimate_normals, render_depth
    from catpose.datasets.shapes import make_shape
    from catpose.datasets.views import ViewOptions

    rng = np.random.default_rng(seed)
    mesh = make_shape("chair", rng)
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    pts, nrm = sample_outer_surface(V, F, 1500, rng)
    template = Template(f"test/ppf-chair/{seed}", "chair", pts, nrm, V, F)
    cam = PinholeCamera(160, 120, 150.0, 150.0, 80.0, 60.0)
    T_camera_object = ViewOptions(distance=3.0).sample(rng)
    with np.errstate(over="ignore"):
        depth = render_depth(V, F, T_camera_object, cam)
    points, _ = depth_to_points(depth, cam)
    normals = estimate_normals(points, radius=0.08)
    up = apply_R(T_camera_object[:3, :3], np.array([0.0, 0.0, 1.0]))
    problem = RegistrationProblem(f"chair{seed}", "chair", points, normals, up, template)
    return problem, invert_T(T_camera_object), float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def _errors(T_est: np.ndarray, T_gt: np.ndarray) -> tuple[float, float]:
    """(rotation error in degrees, distance between the estimated and true object positions in the camera frame)."""
    R = T_est[:3, :3].T @ T_gt[:3, :3]
    angle = float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))
    return angle, float(np.linalg.norm(invert_T(T_est)[:3, 3] - invert_T(T_gt)[:3, 3]))


@pytest.fixture(scope="module", params=[0, 1])
def chair(request):
    return _rendered_chair(request.param)


def test_recovers_a_rendered_template_at_a_known_pose(chair) -> None:
    """The frames are settled: OpenCV's pose maps the model into the camera, the answer is its
    inverse, within 2 degrees and 2 % of the diameter."""
    pytest.importorskip("cv2.ppf_match_3d")
    from catpose.methods.ppf import PPF

    problem, T_gt, diameter = chair
    result = PPF(**COARSE).register(problem)
    angle, offset = _errors(result.T_template_camera, T_gt)
    assert angle < 2.0 and offset < 0.02 * diameter, (angle, offset / diameter)
    assert result.candidates_T.shape == (2, 4, 4) and np.isfinite(result.score)
    assert result.score == pytest.approx(result.candidate_scores[result.extras["chosen_index"]])


def test_model_cache_selection_and_determinism(chair) -> None:
    """One trained model per template content and setting in the process, shared by instances;
    each selection rule picks its candidate; the same problem gives the same bits."""
    pytest.importorskip("cv2.ppf_match_3d")
    from catpose.methods import ppf

    problem = chair[0]
    detector = ppf.PPF(**COARSE).model(problem.template)[0]
    assert ppf.PPF(**COARSE).model(problem.template)[0] is detector
    assert ppf.PPF(**dict(COARSE, model_sampling=0.09)).model(problem.template)[0] is not detector
    results = {select: ppf.PPF(**COARSE, select=select).register(problem) for select in ppf.SELECTIONS}
    e = results["votes"].extras
    assert e["votes"] == sorted(e["votes"], reverse=True)
    best = {
        "votes": 0,
        "residual": int(np.argmin(e["icp_residual"])),
        "chamfer": int(np.argmin(e["candidate_chamfer"])),
    }
    for select, r in results.items():
        assert r.extras["chosen_index"] == best[select], select
        np.testing.assert_array_equal(r.candidates_T, results["votes"].candidates_T)  # deterministic


def test_missing_opencv_contrib_says_how_to_install(monkeypatch) -> None:
    from catpose.methods import ppf

    monkeypatch.setitem(sys.modules, "cv2", None)  # `import cv2` now raises ImportError
    with pytest.raises(ConfigError, match=r"pip install -e '\.\[ppf\]'") as info:
        ppf.PPF()
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    "kwargs,key",
    [
        (dict(model_sampling=0), "model_sampling"),
        (dict(scene_sampling=1.5), "scene_sampling"),
        (dict(select="best"), "select"),
        (dict(icp_model="half"), "icp_model"),
        (dict(top_k=0), "top_k"),
    ],
)
def test_bad_options_are_one_line(kwargs: dict, key: str) -> None:
    from catpose.methods.ppf import PPF

    with pytest.raises(ConfigError, match=key):
        PPF(**kwargs)
