"""The depth-sensor model (catpose.datasets.sensor) and its hookup in the synthetic set."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from catpose.datasets.render import PinholeCamera, render_depth
from catpose.datasets.sensor import KINECT, REALSENSE, apply_sensor, get_sensor, table_mesh
from catpose.errors import ConfigError
from catpose.geometry import axis_angle_to_R, make_T

CAM = PinholeCamera(160, 120, 150.0, 150.0, 79.5, 59.5)


def plane_depth(z: float, tilt_deg: float) -> np.ndarray:
    """Depth (m) of a large plane through (0, 0, z) tilted by ``tilt_deg`` about the camera's y
    axis (0: fronto-parallel), rendered through the same ray caster as the datasets."""
    v, f = table_mesh(0.0, half_size=20.0)  # the plane z = 0, normal +z
    R = axis_angle_to_R(np.array([0.0, 1.0, 0.0]), np.deg2rad(180.0 + tilt_deg))  # normal towards the camera
    return render_depth(v, f, make_T(R, np.array([0.0, 0.0, z])), CAM).astype(np.float64)


def interior(a: np.ndarray, border: int = 5) -> np.ndarray:
    return a[border:-border, border:-border]


def test_presets_and_unknown_name():
    assert get_sensor("none") is None and get_sensor(None) is None
    assert get_sensor("kinect") is KINECT and get_sensor("realsense") is REALSENSE
    with pytest.raises(ConfigError, match="dataset.sensor"):
        get_sensor("lidar")


def test_deterministic_by_seed():
    depth = plane_depth(1.2, 30.0)
    mask = np.zeros_like(depth, bool)
    mask[40:80, 60:100] = True
    a = apply_sensor(depth, mask, CAM.fx, CAM.fy, CAM.cx, CAM.cy, KINECT, np.random.default_rng(7))
    b = apply_sensor(depth, mask, CAM.fx, CAM.fy, CAM.cx, CAM.cy, KINECT, np.random.default_rng(7))
    c = apply_sensor(depth, mask, CAM.fx, CAM.fy, CAM.cx, CAM.cy, KINECT, np.random.default_rng(8))
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[0], c[0])


@pytest.mark.parametrize("z", [0.8, 1.5, 2.5])
def test_axial_noise_std_matches_nguyen(z):
    """On a fronto-parallel plane, without quantisation or dropout, the depth noise std is the
    formula's sigma_z(z, 0) = 0.0012 + 0.0019 (z - 0.4)^2 within 5 % (~15,000 pixels)."""
    sensor = dataclasses.replace(KINECT, subpixel_steps=0.0, dropout_start_deg=89.0, dropout_end_deg=90.0)
    assert sensor.axial_sigma(z) == pytest.approx(0.0012 + 0.0019 * (z - 0.4) ** 2)
    depth = plane_depth(z, 0.0)
    out, _ = apply_sensor(
        depth, np.zeros_like(depth, bool), CAM.fx, CAM.fy, CAM.cx, CAM.cy, sensor, np.random.default_rng(0)
    )
    diff = interior(out - depth)
    assert abs(diff.mean()) < 4 * sensor.axial_sigma(z) / np.sqrt(diff.size)
    assert diff.std() == pytest.approx(float(sensor.axial_sigma(z)), rel=0.05)


def test_disparity_quantisation_steps():
    """Quantised depth lies on the disparity grid f b / (k / steps); neighbouring levels near 1 m
    are z^2 / (f b steps) apart (2.9 mm for the Kinect); quantising twice changes nothing."""
    fb = KINECT.disparity_focal_px * KINECT.baseline_m
    z = np.linspace(0.9, 1.1, 2001)
    q = KINECT.quantize(z)
    k = fb * KINECT.subpixel_steps / q
    assert np.allclose(k, np.round(k), atol=1e-6)
    levels = np.unique(np.round(q, 9))
    step = np.diff(levels)[len(levels) // 2]
    assert step == pytest.approx(1.0 / (fb * KINECT.subpixel_steps), rel=0.05)
    assert np.abs(q - z).max() <= 0.5 * levels.max() ** 2 / (fb * KINECT.subpixel_steps) * 1.05
    assert np.array_equal(KINECT.quantize(q), q)
    assert KINECT.quantize(np.array([0.0]))[0] == 0.0


def test_dropout_grows_with_grazing_angle():
    sensor = dataclasses.replace(KINECT, axial_c=0.0)  # keep the noise small so only dropout differs
    missing = []
    for tilt in (0.0, 50.0, 75.0, 82.0, 86.0):
        depth = plane_depth(1.5, tilt)
        out, _ = apply_sensor(
            depth, np.zeros_like(depth, bool), CAM.fx, CAM.fy, CAM.cx, CAM.cy, sensor, np.random.default_rng(1)
        )
        valid = interior(depth) > 0
        missing.append(float((interior(out)[valid] == 0).mean()))
    # the image spans +-28 deg, so a 50-degree plane has a few pixels past the 70-degree onset
    assert missing[0] < 0.005 and missing[1] < 0.1
    assert missing[1] < missing[2] < missing[3] < missing[4]
    assert missing[4] > 0.7


def test_mask_bleeds_into_background_and_edges_get_noise():
    depth = plane_depth(1.5, 0.0)
    mask = np.zeros_like(depth, bool)
    mask[40:80, 60:100] = True
    depth[mask] -= 0.2  # a box standing in front of the plane
    sensor = dataclasses.replace(KINECT, flying_pixel_prob=1.0)
    out, observed = apply_sensor(depth, mask, CAM.fx, CAM.fy, CAM.cx, CAM.cy, sensor, np.random.default_rng(2))
    bleed = observed & ~mask
    assert bleed.sum() > 0 and np.all(np.abs(depth[bleed] - 1.5) < 1e-6)
    edge_rows = out[40, 62:98]  # the box's top edge: flying pixels between layers
    assert ((edge_rows > 1.3 + 0.02) & (edge_rows < 1.5 - 0.02)).any()


def test_synthetic_sensor_observation_is_deterministic_and_metric():
    from catpose.datasets.synthetic import SyntheticDataset

    kw = dict(seed=3, categories=["mug"], instances_per_category=1, views_per_instance=1, sensor="kinect")
    a = SyntheticDataset(**kw).observation("mug/000/v00")
    b = SyntheticDataset(**kw).observation("mug/000/v00")
    assert np.array_equal(a.points_camera, b.points_camera) and np.array_equal(a.normals_camera, b.normals_camera)
    assert np.array_equal(a.ground_normal_camera, b.ground_normal_camera)
    assert a.info["sensor"] == "kinect" and a.info["scale_mm"] == pytest.approx(70.0)
    assert 0.4 <= a.info["distance_m"] <= 1.2
    assert a.info["ground_vs_object_up_deg"] < 3.0  # the table-plane fit recovers gravity
    # the clean default is untouched by the sensor option
    clean = SyntheticDataset(**dict(kw, sensor="none")).observation("mug/000/v00")
    assert "sensor" not in clean.info
