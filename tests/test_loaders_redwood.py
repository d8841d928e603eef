"""Redwood loader on frames rendered here (a box on a floor, 16-bit mm PNGs, a ``.log``
trajectory) and on the shared Redwood chair frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from catpose.datasets.depthio import read_log_trajectory
from catpose.datasets.redwood import Redwood
from catpose.datasets.render import PinholeCamera, render_depth
from catpose.datasets.templates import TemplateOptions
from catpose.errors import DatasetError
from catpose.geometry import invert_T, look_at_T_camera_world, transform_points

# PrimeSense intrinsics at a quarter of the resolution, to keep the test fast
CAM = dict(width=160, height=120, fx=131.25, fy=131.25, cx=79.5, cy=59.5)
BOX = np.array([0.6, 0.4, 0.8])  # metres, standing on the floor at the origin
EYES = [np.array([1.6, -1.2, 1.3]), np.array([-0.4, -1.9, 1.1])]


def write_log_trajectory(path: Path, poses: list[np.ndarray]) -> None:
    """Write ``T_world_camera`` (4, 4) poses, frame indices 0.., in the Redwood ``.log`` format."""
    with open(path, "w") as fh:
        for i, T in enumerate(poses):
            fh.write(f"{i} {i} {len(poses)}\n")
            for row in np.asarray(T, float):
                fh.write(" ".join(f"{x:.10f}" for x in row) + "\n")


def scene_mesh() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    box = trimesh.creation.box(extents=BOX)
    box.apply_translation([0, 0, BOX[2] / 2])
    floor_v = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], float)
    v = np.concatenate([floor_v, box.vertices])
    f = np.concatenate([[[0, 1, 2], [0, 2, 3]], np.asarray(box.faces) + 4])
    return v, f


def T_world_camera(k: int) -> np.ndarray:
    return invert_T(look_at_T_camera_world(EYES[k], np.array([0.0, 0.0, 0.4]), np.array([0.0, 0.0, 1.0])))


@pytest.fixture()
def redwood_root(tmp_path) -> Path:
    from PIL import Image

    root = tmp_path / "redwood"
    scan = root / "chair_00001"
    (scan / "depth").mkdir(parents=True)
    v, f = scene_mesh()
    camera = PinholeCamera(**CAM)
    for k in range(2):
        depth_m = render_depth(v, f, invert_T(T_world_camera(k)), camera)
        Image.fromarray(np.round(depth_m * 1000).astype(np.uint16)).save(scan / "depth" / f"{k + 1:07d}-000.png")
    write_log_trajectory(scan / "trajectory.log", [T_world_camera(0), T_world_camera(1)])
    return root


def test_frames_floor_object_and_trajectory(redwood_root):
    ds = Redwood(str(redwood_root), **CAM, max_points=0)
    assert ds.observation_ids() == ["chair/chair_00001/0000", "chair/chair_00001/0001"]
    scale = ds.scale_m("chair_00001")
    # radius about the camera-frame bounding-box centre of the visible part: near the box's 0.539
    assert 0.45 < scale < 0.65
    for k in range(2):
        obs = ds.observation(f"chair/chair_00001/{k:04d}")
        info = obs.info
        assert info["absolute_gt"] is False and info["relative_gt"] is True and info["pose_source"] == "trajectory"
        assert info["scale_m"] == pytest.approx(scale)
        R_camera_world = T_world_camera(k)[:3, :3].T
        assert np.degrees(np.arccos(obs.ground_normal_camera @ (R_camera_world @ [0, 0, 1]))) < 2.0
        p_world = transform_points(T_world_camera(k), obs.points_camera * scale)
        assert p_world[:, 2].min() > 0.015  # the floor is gone
        q = np.abs(p_world - [0, 0, BOX[2] / 2])
        assert np.all(q <= BOX / 2 + 0.03)  # only box points (voxel-averaged within 1.25 cm)
        # the depth image (object unit) and the object's pixels: they back-project onto the box
        di = obs.depth_image
        assert di is not None and di.mask.any() and not di.mask.all()
        rows, cols = np.nonzero(di.mask)
        z = di.depth[rows, cols] * scale
        x, y = (cols - CAM["cx"]) * z / CAM["fx"], (rows - CAM["cy"]) * z / CAM["fy"]
        m_world = transform_points(T_world_camera(k), np.stack([x, y, z], axis=1))
        assert np.all(np.abs(m_world - [0, 0, BOX[2] / 2]) <= BOX / 2 + 0.03)
        expected = T_world_camera(k).copy()
        expected[:3, 3] /= scale
        np.testing.assert_allclose(obs.T_object_camera, expected, atol=1e-9)
    T0 = ds.observation("chair/chair_00001/0000").T_object_camera
    T1 = ds.observation("chair/chair_00001/0001").T_object_camera
    rel = invert_T(T0) @ T1  # the relative camera motion in normalised units
    true = invert_T(T_world_camera(0)) @ T_world_camera(1)
    np.testing.assert_allclose(rel[:3, :3], true[:3, :3], atol=1e-9)
    np.testing.assert_allclose(rel[:3, 3] * scale, true[:3, 3], atol=1e-9)


def test_without_trajectory_the_pose_is_identity_and_the_size_can_be_given(redwood_root):
    (redwood_root / "chair_00001/trajectory.log").unlink()
    ds = Redwood(str(redwood_root), **CAM, object_size=0.5, max_points=300)
    obs = ds.observation("chair/chair_00001/0001")
    np.testing.assert_array_equal(obs.T_object_camera, np.eye(4))
    assert obs.info["pose_source"] == "none" and obs.info["relative_gt"] is False
    assert obs.info["scale_m"] == 0.5 and obs.info["scale_source"] == "config"
    assert len(obs.points_camera) == 300


def test_observations_are_deterministic(redwood_root):
    a = Redwood(str(redwood_root), **CAM, max_points=200).observation("chair/chair_00001/0001")
    b = Redwood(str(redwood_root), **CAM, max_points=200).observation("chair/chair_00001/0001")
    np.testing.assert_array_equal(a.points_camera, b.points_camera)
    np.testing.assert_array_equal(a.ground_normal_camera, b.ground_normal_camera)


def test_log_round_trip_and_malformed_log(tmp_path):
    Ts = [T_world_camera(0), T_world_camera(1)]
    write_log_trajectory(tmp_path / "t.log", Ts)
    got = read_log_trajectory(tmp_path / "t.log")
    assert sorted(got) == [0, 1]
    np.testing.assert_allclose(got[1], Ts[1], atol=1e-9)
    (tmp_path / "bad.log").write_text("0 0 1\n1 0 0 0\n0 1 0 0\n")
    with pytest.raises(DatasetError, match="bad.log is malformed"):
        read_log_trajectory(tmp_path / "bad.log")


def test_bad_input_raises_dataset_errors(redwood_root):
    from PIL import Image

    with pytest.raises(DatasetError, match="not a folder"):
        Redwood(str(redwood_root / "nope"))
    with pytest.raises(DatasetError, match="intrinsics"):
        Redwood(str(redwood_root)).observation("chair/chair_00001/0000")  # 640x480 intrinsics, 160x120 PNG
    (redwood_root / "chair_00001/trajectory.log").write_text("0 0 1\nx\n")
    with pytest.raises(DatasetError, match="trajectory.log"):
        Redwood(str(redwood_root), **CAM).observation("chair/chair_00001/0000")
    (redwood_root / "scan9").mkdir()
    (redwood_root / "scan9/depth").mkdir()
    Image.fromarray(np.zeros((120, 160, 3), np.uint8)).save(redwood_root / "scan9/depth/0001.png")
    ds = Redwood(str(redwood_root), **CAM, scans=["scan9"], scan_categories={"scan9": "mug"}, trajectory=None)
    assert ds.observation_ids() == ["mug/scan9/0000"]
    with pytest.raises(DatasetError, match="0001.png is uint8"):
        ds.observation("mug/scan9/0000")
    with pytest.raises(DatasetError, match="no category for scan 'scan9'"):
        Redwood(str(redwood_root), scans=["scan9"]).observation_ids()
    with pytest.raises(DatasetError, match="no complete model"):
        ds.instance_model("mug", "scan9")


@pytest.mark.data
def test_shared_redwood_chair_frames(shared_data):
    ds = Redwood(
        str(shared_data / "redwood"),
        max_points=1000,
        template=TemplateOptions(
            templates={"chair": [{"path": "../shapenet/chair/models/model_normalized.obj", "up": "+y"}]},
            template_points=256,
        ),
    )
    ids = ds.observation_ids()
    assert ids == ["chair/chair_00286/0000", "chair/chair_00286/0001", "chair/chair_00286/0002"]
    obs = ds.observation(ids[1])
    assert obs.info["pose_source"] == "none" and 0.2 < obs.info["scale_m"] < 1.5
    assert obs.ground_normal_camera[1] < -0.7  # an upright camera looks at the floor: up is image-up (-y)
    assert obs.points_camera.shape == (1000, 3)
    (t,) = ds.category_templates("chair")
    assert t.category == "chair" and np.ptp(t.vertices[:, 2]) > np.ptp(t.vertices[:, 0])
