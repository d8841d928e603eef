"""The datasets' option groups (datasets/views.py, datasets/templates.py) and how a config's flat
keys reach them (bench/run/build.py)."""

from __future__ import annotations

import numpy as np
import pytest

from catpose.bench.run.build import build_from_config
from catpose.datasets.views import ImageOptions, ViewOptions
from catpose.errors import ConfigError
from catpose.geometry import invert_T


def build(**keys):
    return build_from_config(dict(keys), "dataset")[1]


def test_image_options_give_the_camera():
    cam = ImageOptions(width=200, height=100, fx=50.0, fy=60.0).camera()
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (50.0, 60.0, 99.5, 49.5)
    assert ImageOptions(width=200, height=100, fov_deg=90.0).camera().fx == pytest.approx(100.0)
    with pytest.raises(ConfigError, match="dataset.fov_deg=180"):
        ImageOptions(fov_deg=180.0).camera()
    with pytest.raises(ConfigError, match="dataset.height=0"):
        ImageOptions(height=0).camera()


def test_view_options_refuse_a_camera_inside_the_object():
    with pytest.raises(ConfigError, match="dataset.distance=0.5"):
        ViewOptions(distance=0.5)
    assert ViewOptions(distance=4.0).sample(np.random.default_rng(0))[:3, 3] == pytest.approx([0.0, 0.0, 4.0])


def test_flat_keys_fill_the_groups_over_the_constructor_default(tmp_path):
    (tmp_path / "modelnet40_train.txt").write_text("")
    ds = build(
        _target_="catpose.datasets.synthetic.SyntheticDataset", distance=4.0, fx=150.0, categories=["mug"], max_points=9
    )
    assert ds.view == ViewOptions(distance=4.0, max_points=9) and ds.camera.fx == 150.0 and ds.camera.fy == 300.0
    target = "catpose.datasets.modelnet40_resampled.ModelNet40Resampled"
    table = tmp_path / "table.csv"
    table.write_text("category,instance_id,yaw_deg\n")
    ds = build(_target_=target, root=str(tmp_path), alignment_table=str(table), symmetric={"bowl": [0, 0, 1]})
    # the resampled release's own axes (+y up, -x forward) stay when only the table is given
    assert ds.R_template_file.tolist() == [[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]
    assert ds.alignment_table == str(table) and ds.symmetric["bowl"].tolist() == [0.0, 0.0, 1.0]


def test_a_key_no_group_takes_is_refused_and_a_bad_value_names_its_key(tmp_path):
    target = "catpose.datasets.modelnet40_resampled.ModelNet40Resampled"
    with pytest.raises(ConfigError, match="dataset.fx is not an option of dataset"):
        build(_target_=target, root=str(tmp_path), fx=300.0)  # no image: views by hidden point removal
    with pytest.raises(ConfigError, match=r"dataset.fx='abc' is not a float; set dataset.fx=<number>"):
        build(_target_="catpose.datasets.synthetic.SyntheticDataset", fx="abc")


def test_view_options_look_at_the_object() -> None:
    sampler = ViewOptions(distance=2.5, elevation_min_deg=10.0, elevation_max_deg=60.0, roll_max_deg=20.0)
    rng = np.random.default_rng(3)
    for _ in range(20):
        T_camera_object = sampler.sample(rng)
        R = T_camera_object[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        # the object origin is on the optical axis at the sampled distance
        np.testing.assert_allclose(T_camera_object[:3, 3], [0.0, 0.0, 2.5], atol=1e-12)
        eye = invert_T(T_camera_object)[:3, 3]
        elevation = np.rad2deg(np.arcsin(eye[2] / np.linalg.norm(eye)))
        assert 10.0 - 1e-9 <= elevation <= 60.0 + 1e-9
