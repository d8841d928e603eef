"""``catpose.register``: a known pose of an asymmetric object, in millimetres, recovered in one call.

The scene is made here: a procedurally generated chair (``catpose.datasets.shapes``) scaled to
millimetres with its template-frame origin off the object's centre, seen as a rendered partial
depth view from a known camera. Errors are checked in the caller's frame and unit.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import catpose
from catpose.errors import InvalidInputError
from catpose.geometry import invert_T, look_at_T_camera_world, make_T

MM_PER_UNIT = 450.0  # the chair's radius, mm
OFFSET_MM = np.array([120.0, -35.0, 260.0])  # template-frame origin away from the chair's centre


def _rot_err_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R_a.T @ R_b) - 1.0) / 2.0, -1.0, 1.0))))


@pytest.fixture(scope="module")
def scene():
    """A chair template in mm (vertices, faces), its partial view in mm (camera frame), the true
    ``T_template_camera`` (mm) and the up direction in the camera frame."""
    from catpose.datasets.render import depth_to_points, render_depth
    from catpose.datasets.shapes import make_shape
    from catpose.datasets.views import pinhole_camera

    mesh = make_shape("chair", np.random.default_rng(3))  # unit sphere, z up, asymmetric
    el, az = np.deg2rad(35.0), np.deg2rad(70.0)
    eye = 3.0 * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    T_camera_unit = look_at_T_camera_world(eye, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    camera = pinhole_camera(320, 240, 300.0, 300.0, None, None)
    points_unit, _ = depth_to_points(render_depth(mesh.vertices, mesh.faces, T_camera_unit, camera), camera)
    T_unit_camera = invert_T(T_camera_unit)
    # p_template_mm = S p_unit + o, p_unit = R p_camera_unit + t, p_camera_unit = p_camera_mm / S
    T_gt = make_T(T_unit_camera[:3, :3], MM_PER_UNIT * T_unit_camera[:3, 3] + OFFSET_MM)
    return {
        "vertices": mesh.vertices * MM_PER_UNIT + OFFSET_MM,
        "faces": np.asarray(mesh.faces),
        "observation": points_unit * MM_PER_UNIT,
        "T_gt": T_gt,
        "up": T_camera_unit[:3, 2].copy(),
        "mesh": mesh,
    }


def _errors(T: np.ndarray, T_gt: np.ndarray) -> tuple[float, float]:
    return _rot_err_deg(T[:3, :3], T_gt[:3, :3]), float(np.linalg.norm(T[:3, 3] - T_gt[:3, 3]))


def test_icp_recovers_the_pose_in_millimetres(scene):
    r = catpose.register(scene["observation"], (scene["vertices"], scene["faces"]), method="icp")
    rot, trans = _errors(r.T_template_camera, scene["T_gt"])
    assert rot < 5.0 and trans < 0.03 * MM_PER_UNIT, (rot, trans)
    assert r.method == "icp" and r.up_camera is None and abs(r.scale - MM_PER_UNIT) < 0.01 * MM_PER_UNIT
    assert r.candidates.shape == (20, 4, 4) and r.candidate_scores.shape == (20,)
    assert any(np.allclose(c, r.T_template_camera) for c in r.candidates)
    again = catpose.register(scene["observation"], (scene["vertices"], scene["faces"]), method="icp")
    assert np.array_equal(again.T_template_camera, r.T_template_camera)  # deterministic


@pytest.mark.usefixtures("private_cache_dir", "one_torch_thread")
def test_ours_recovers_the_pose_with_and_without_up(scene):
    template = (scene["vertices"], scene["faces"])
    r = catpose.register(scene["observation"], template, method="ours", up=scene["up"])
    rot, trans = _errors(r.T_template_camera, scene["T_gt"])
    assert rot < 5.0 and trans < 0.03 * MM_PER_UNIT, (rot, trans)
    assert np.allclose(r.up_camera, scene["up"]) and len(r.candidates) == 18
    # without up: ours runs once per up hypothesis and keeps the best score (docs/api.md)
    n = catpose.api.UP_HYPOTHESES
    free = catpose.register(scene["observation"], template, method="ours")
    rot, trans = _errors(free.T_template_camera, scene["T_gt"])
    assert rot < 5.0 and trans < 0.03 * MM_PER_UNIT, (rot, trans)
    search = free.extras["up_search"]
    assert len(search["hypotheses"]) == n and len(free.candidates) == 18 * n
    assert free.score == min(search["scores"])
    assert float(np.degrees(np.arccos(np.clip(free.up_camera @ scene["up"], -1, 1)))) < 45.0


def test_template_forms_give_the_same_answer(scene, tmp_path):
    import trimesh

    reference = catpose.register(scene["observation"], (scene["vertices"], scene["faces"]), method="icp")
    mesh = trimesh.Trimesh(scene["vertices"], scene["faces"], process=False)
    path = tmp_path / "chair.ply"
    mesh.export(path)
    for form in (mesh, str(path), path):
        r = catpose.register(scene["observation"], form, method="icp")
        assert np.allclose(r.T_template_camera, reference.T_template_camera, atol=1e-6), type(form)


def test_point_cloud_template_with_estimated_normals(scene):
    from catpose.datasets.meshio import sample_outer_surface

    points, _ = sample_outer_surface(scene["mesh"].vertices, scene["mesh"].faces, 3000, 7)
    cloud_mm = points * MM_PER_UNIT + OFFSET_MM
    r = catpose.register(scene["observation"], cloud_mm, method="icp")
    rot, trans = _errors(r.T_template_camera, scene["T_gt"])
    assert rot < 5.0 and trans < 0.03 * MM_PER_UNIT, (rot, trans)


def test_template_up_other_than_z(scene):
    """A template whose up axis is +y: the pose comes back in that template's own frame."""
    R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # z -> y
    vertices = scene["vertices"] @ R.T
    r = catpose.register(scene["observation"], (vertices, scene["faces"]), method="icp", template_up=(0, 1, 0))
    T_gt = make_T(R @ scene["T_gt"][:3, :3], R @ scene["T_gt"][:3, 3])
    rot, trans = _errors(r.T_template_camera, T_gt)
    assert rot < 5.0 and trans < 0.03 * MM_PER_UNIT, (rot, trans)


def test_options_reach_the_builder():
    from catpose.methods.descriptors import PFH

    assert catpose.build_method("icp", num_starts=4).num_starts == 4
    ours = catpose.build_method("ours", selection={"gravity_max_deg": None}, descriptor="pfh")
    assert ours.selection.gravity_max_deg is None and isinstance(ours.descriptor, PFH)
    assert catpose.build_method("icp", num_starts=4) is catpose.build_method("icp", num_starts=4)  # cached


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        ({"observation": np.zeros(5)}, "observation has shape (5,); expected (N, 3)"),
        ({"observation": np.full((20, 3), np.nan)}, "observation has 20 rows with NaN or inf"),
        ({"observation": np.zeros((3, 3))}, "observation has 3 points; at least 10 are needed"),
        ({"observation": "points.ply"}, "observation is a str, not an (N, 3) array"),
        ({"template": "/nonexistent/chair.ply"}, "template: mesh file /nonexistent/chair.ply does not exist"),
        ({"template": (np.eye(3), np.array([[0, 1, 5]]))}, "template faces index vertices outside 0..2"),
        ({"template": np.zeros((50, 3))}, "template has zero extent (all 50 points equal)"),
        ({"up": [0.0, 0.0, 0.0]}, "up=[0.0, 0.0, 0.0] is not a finite non-zero 3-vector"),
        ({"up": [1.0, 2.0]}, "up=[1.0, 2.0] is not a finite non-zero 3-vector"),
        ({"method": "nope"}, "method='nope' is not a method config; choose one of"),
        ({"method": 3}, "method is a int; pass a config name"),
        (
            {"method": "icp", "foo": 1},
            "foo is not an option of method 'icp'; its options are: max_correspondence_distances,",
        ),
        (
            {"method": "icp", "num_starts": "many"},
            "options of method 'icp': method.num_starts='many' must be a positive integer",
        ),
        ({"observation_normals": np.ones((4, 3))}, "observation_normals has shape (4, 3); expected (200, 3)"),
        ({"template_up": [0, 0, 0]}, "template_up=[0, 0, 0] is not a finite non-zero 3-vector"),
        ({"max_points": -1}, "max_points=-1 is not a positive integer"),
    ],
)
def test_bad_inputs_raise_one_line_errors_naming_the_argument(kwargs, needle):
    rng = np.random.default_rng(0)
    args = {"observation": rng.normal(size=(200, 3)), "template": rng.normal(size=(300, 3)), "method": "icp"}
    args.update(kwargs)
    with pytest.raises(InvalidInputError) as info:
        catpose.register(**args)
    assert needle in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_instance_methods_take_no_options(scene):
    method = catpose.build_method("icp", num_starts=2)
    with pytest.raises(InvalidInputError, match="apply to a method config name, not to an instance"):
        catpose.register(scene["observation"], (scene["vertices"], scene["faces"]), method=method, num_starts=3)
    r = catpose.register(scene["observation"], (scene["vertices"], scene["faces"]), method=method)
    assert r.method == "ICP" and len(r.candidates) == 2


def test_import_catpose_stays_light():
    probe = (
        "import sys, catpose; heavy = [m for m in ('catpose.api', 'torch', 'hydra', 'open3d', 'trimesh') "
        "if m in sys.modules]; assert not heavy, heavy; assert callable(catpose.register); "
        "assert 'catpose.api' in sys.modules; assert 'register' in dir(catpose)"
    )
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
