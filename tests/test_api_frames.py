"""``catpose.register`` and ``catpose.Registrar`` from a depth frame (``catpose.DepthFrame``): the
frame's checks, the table plane, the unit check, and the issue-42 cases of the API (16, 29, 35, 36).

The frame is the shipped example (``examples/data``, written by ``examples/make_example_data.py``):
a procedural chair of the embedded synthetic set in millimetres on a floor, 200 x 150 pixels, with
its true pose. The agreement of ``register(DepthFrame)`` with ``bench run`` on the shared YCB-Video
frames is in ``tests/test_api_bench_agreement.py``.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import catpose
from catpose.errors import InvalidInputError, RegistrationFailed

pytestmark = pytest.mark.usefixtures("private_cache_dir", "one_torch_thread")


def rotation_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """The angle between two rotations, exact near 0 (``2 asin(|R_a - R_b|_F / sqrt 8)``)."""
    return float(np.degrees(2.0 * np.arcsin(min(1.0, np.linalg.norm(R_a - R_b) / np.sqrt(8.0)))))


@pytest.fixture(scope="module")
def example(repo_root):
    data = np.load(repo_root / "examples" / "data" / "chair_frame.npz")
    return {
        "depth": data["depth"],
        "K": data["K"],
        "mask": data["mask"],
        "T": data["T_template_camera"],
        "ply": str(repo_root / "examples" / "data" / "chair.ply"),
    }


def _frame(example, **kw):
    args = {"depth": example["depth"], "K": example["K"], "mask": example["mask"]}
    args.update(kw)
    return catpose.DepthFrame(**args)


def test_ours_from_a_frame_fits_the_table_and_finds_the_pose(example):
    r = catpose.register(_frame(example), example["ply"], method="ours")
    assert rotation_deg(r.T_template_camera[:3, :3], example["T"][:3, :3]) < 5.0
    assert np.linalg.norm(r.T_template_camera[:3, 3] - example["T"][:3, 3]) < 0.03 * r.scale
    assert r.extras["ground_source"] == "plane" and r.extras["ground_inliers"] > 1000
    true_up = example["T"][:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the template's +z seen from the camera
    assert np.degrees(np.arccos(np.clip(r.up_camera @ true_up, -1, 1))) < 2.0
    assert r.extras["visible_pixels"] == int((example["mask"] & (example["depth"] > 0)).sum())
    again = catpose.register(_frame(example), example["ply"], method="ours")
    assert np.array_equal(again.T_template_camera, r.T_template_camera)  # deterministic
    # the runner-up: another answer (> 10 deg off), in the caller's frame and unit, as ours named it
    assert r.runner_up is not None and rotation_deg(r.runner_up[:3, :3], r.T_template_camera[:3, :3]) > 10.0
    second = r.extras["runner_up"]
    assert r.runner_up_margin == second["margin"] >= 0.0
    T2 = np.asarray(second["T_template_camera"])  # normalised frames, mapped as the answer is
    assert np.allclose(r.runner_up[:3, :3] @ T2[:3, :3].T, r.T_template_camera[:3, :3] @ r.T_normalised[:3, :3].T)


def test_a_method_without_a_runner_up_leaves_it_empty(example):
    r = catpose.register(_frame(example), example["ply"], method="icp")
    assert r.runner_up is None and np.isnan(r.runner_up_margin)


@pytest.mark.slow  # > 5 s: make test-slow
def test_a_registrar_holds_the_template_for_several_views(example):
    reg = catpose.Registrar(example["ply"], method="icp")
    first = reg(_frame(example))
    assert rotation_deg(first.T_template_camera[:3, :3], example["T"][:3, :3]) < 5.0
    second = reg(_frame(example, frame_id="second"), first.up_camera)
    assert second.extras["ground_source"] == "given" and first.extras["ground_source"] == "plane"


def test_without_a_mask_the_up_search_decides(example):
    depth = np.where(example["mask"], example["depth"], 0)  # only the chair was measured
    r = catpose.register(catpose.DepthFrame(depth, example["K"]), example["ply"], method="icp")
    assert r.extras["ground_source"] == "search" and r.up_camera is None  # icp uses no up
    assert rotation_deg(r.T_template_camera[:3, :3], example["T"][:3, :3]) < 5.0


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"mask": np.ones((10, 10), bool)}, "mask is (10, 10) but depth is (150, 200); pass the object's mask"),
        ({"mask": np.zeros((150, 200), bool)}, "mask is empty (no True pixel)"),
        ({"K": np.eye(2)}, "K has shape (2, 2)"),
        ({"K": np.array([[200.0, 0, 0], [0, 200.0, 0], [99.5, 74.5, 1]])}, "it is transposed; pass K.T"),
        ({"K": np.diag([-200.0, 200.0, 1.0])}, "focal lengths fx=-200, fy=200; they must be positive"),
        ({"K": np.array([[200.0, 3, 99.5], [0, 200.0, 74.5], [0, 0, 1]])}, "K has skew or shear"),
        ({"K": np.diag([200.0, 200.0, 2.0])}, "K[2, 2] is 2, not 1"),
        ({"depth": np.ones((150, 200), bool)}, "depth has dtype bool"),
        ({"depth": np.ones((150, 200, 3))}, "depth has shape (150, 200, 3); expected (H, W)"),
        ({"depth": -np.ones((150, 200))}, "depth has 30000 negative values"),
        ({"depth": np.zeros((150, 200))}, "depth has no measured pixel"),
        ({"depth_scale": 0.0}, "depth_scale=0.0 must be a positive finite number"),
        ({"depth_scale": "1"}, "depth_scale='1' is not a number"),
        ({"mask": np.full((150, 200), 0.5)}, "mask has dtype float64; pass an (H, W) bool array"),
    ],
)
def test_depth_frame_errors_name_the_argument_and_the_fix(example, kwargs, needle):
    with pytest.raises(InvalidInputError) as info:
        _frame(example, **kwargs)
    assert needle in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_a_mask_without_depth_and_a_frame_without_table_are_refused(example):
    hole = example["mask"].copy()
    depth = np.where(hole, 0, example["depth"])
    with pytest.raises(InvalidInputError, match="none has a depth measurement; check that mask and depth"):
        catpose.DepthFrame(depth, example["K"], hole)
    only_chair = np.where(example["mask"], example["depth"], 0)
    frame = catpose.DepthFrame(only_chair, example["K"], example["mask"])
    with pytest.raises(InvalidInputError, match="only 0 background pixels; cannot fit the ground plane; pass up"):
        catpose.register(frame, example["ply"], method="icp")
    with pytest.raises(InvalidInputError, match="observation_normals applies to a point array"):
        catpose.register(frame, example["ply"], method="icp", observation_normals=np.ones((5, 3)))


def test_case_16_observation_in_metres_against_a_template_in_mm_warns_with_the_ratio(example):
    metres = _frame(example, depth_scale=0.001)  # the frame's depth read as metres, the template in mm
    with pytest.warns(UserWarning) as frame_warnings:
        catpose.register(metres, example["ply"], method="icp")
    ratio = r"template radii, 1\.\d+e\+03 times smaller than the template: are they"
    assert any(re.search(ratio, str(w.message)) for w in frame_warnings), [str(w.message) for w in frame_warnings]
    points = np.random.default_rng(0).normal(size=(200, 3)) * 0.05  # a 5 cm cloud in metres
    with pytest.warns(UserWarning) as cloud_warnings:
        catpose.register(points, example["ply"], method="icp")
    assert any("metres against millimetres" in str(w.message) for w in cloud_warnings)
    with warnings.catch_warnings(record=True) as right_units:
        warnings.simplefilter("always")
        result = catpose.register(_frame(example), example["ply"], method="icp")
    assert not right_units, [str(w.message) for w in right_units]  # the right units: no warning at all
    assert np.isfinite(result.T_template_camera).all()


def test_ours_in_the_wrong_unit_is_told_the_unit_not_the_voxel_size(example):
    """Issue 61: after the unit warning, ours' refusal named the voxel size; it names depth_scale."""
    from catpose.api.inputs import normalised_template

    scale = normalised_template(example["ply"], None, np.array([0.0, 0.0, 1.0]), 2048).scale
    voxel = 0.025 * scale  # configs/descriptor/lps.yaml's voxel_size, template radii, in mm
    # a view 1000 times too small, inside one of ours' descriptor voxels: one point is left
    cloud = np.random.default_rng(0).uniform(0.0, 0.1, size=(300, 3)) + voxel * np.array([0.45, 0.45, 10.45])
    with pytest.warns(UserWarning, match="times smaller than the template"), pytest.raises(RegistrationFailed) as info:
        catpose.register(cloud, example["ply"], method="ours", up=[0.0, -1.0, 0.0])
    message = str(info.value)
    assert "set depth_scale" in message and "spans 0.000" in message, message
    assert "lower method.descriptor.voxel_size" not in message and "\n" not in message, message


def test_a_few_stray_mask_pixels_do_not_trigger_the_span_warning(example):
    """A real mask's edge sees past the object (1-2 % of YCB-V's pixels, far behind it): the span
    the unit check reads ignores them; a whole view twice the template's size still warns."""
    mask, depth = example["mask"], example["depth"].astype(float)
    v, u = np.nonzero(mask)
    stray = np.zeros_like(mask)
    stray[v[:: max(1, len(v) // 20)], u[:: max(1, len(v) // 20)]] = True  # ~1 % of the mask
    far = np.where(stray, depth + 5.0 * np.ptp(depth[mask]) + 2000.0, depth)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        catpose.register(catpose.DepthFrame(far, example["K"], mask), example["ply"], method="icp")
    assert not [w for w in caught if "template radii" in str(w.message)], [str(w.message) for w in caught]
    from catpose.api.observation import _radius

    cloud = np.random.default_rng(0).uniform(-3.0, 3.0, size=(500, 3))
    assert 4.5 < _radius(cloud) < 5.3  # a uniform box: the central 95 % of its half diagonal


def test_case_29_too_many_template_points_is_one_line(example, monkeypatch):
    with pytest.raises(InvalidInputError) as info:
        catpose.register(_frame(example), example["ply"], method="icp", template_points=10**9)
    assert "template_points=1000000000 is more than 100000" in str(info.value) and "\n" not in str(info.value)

    def no_memory(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr("catpose.datasets.meshio.sample_outer_surface", no_memory)
    with pytest.raises(InvalidInputError, match="template: out of memory preparing it with template_points=5000"):
        catpose.register(_frame(example), example["ply"], method="icp", template_points=5000)


def test_case_35_far_coordinates_are_not_called_equal():
    rng = np.random.default_rng(0)
    cloud = rng.normal(size=(300, 3))
    for kwargs, name in (
        ({"observation": cloud[:200] + 1e12, "template": cloud}, "observation"),
        ({"observation": cloud[:200], "template": cloud + 1e12}, "template"),
    ):
        with pytest.raises(InvalidInputError) as info:
            catpose.register(method="icp", **kwargs)
        msg = str(info.value)
        assert msg.startswith(f"{name} spans") and "beyond float64's resolution" in msg and "equal" not in msg, msg


def test_case_36_option_errors_list_the_options_not_hydra_advice():
    rng = np.random.default_rng(0)
    args = {"observation": rng.normal(size=(200, 3)), "template": rng.normal(size=(300, 3))}
    with pytest.raises(InvalidInputError) as info:
        catpose.register(method="icp", foo=1, **args)
    assert "foo is not an option of method 'icp'; its options are: max_correspondence_distances" in str(info.value)
    with pytest.raises(InvalidInputError) as info:
        catpose.register(method="ours", selection={"gravity_max_degs": 3}, **args)
    msg = str(info.value)
    assert "selection.gravity_max_degs is not an option of method 'ours'; its selection options are:" in msg
    assert "gravity_max_deg," in msg and "+method" not in msg and "Hydra" not in msg


def test_case_36_a_teaser_failure_on_valid_input_is_not_an_input_error():
    from catpose.datasets.meshio import sample_outer_surface
    from catpose.datasets.shapes import make_shape

    mesh = make_shape("chair", np.random.default_rng(3))
    points, _ = sample_outer_surface(mesh.vertices, mesh.faces, 1500, 1)
    with pytest.raises(RegistrationFailed) as info:  # no consistent correspondences at this noise bound
        catpose.register(points[points[:, 0] > 0], (mesh.vertices, mesh.faces), method="teaser", noise_bound=1e-7)
    assert not isinstance(info.value, InvalidInputError)
    assert str(info.value).startswith("method 'teaser' gave no pose: no pose from any of 1 targets: TEASER max clique")
