"""ModelNet40 (OFF layout) and modelnet40_normal_resampled loaders on fixtures written here,
and on the shared real files when present."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from catpose.datasets.modelnet40 import ModelNet40
from catpose.datasets.modelnet40_resampled import ModelNet40Resampled
from catpose.datasets.templates import TemplateOptions
from catpose.datasets.views import ImageOptions, ViewOptions
from catpose.errors import DatasetError
from catpose.geometry import invert_T, transform_points


def box_mesh(extents=(4.0, 2.0, 1.0), offset=(10.0, -5.0, 3.0)) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    m = trimesh.creation.box(extents=extents)
    return np.asarray(m.vertices) + np.asarray(offset), np.asarray(m.faces)


def write_quirky_off(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        "\r\n".join(
            [f"OFF{len(v)} {len(f)} 0"]
            + [" ".join(f"{x:g}" for x in p) for p in v]
            + [f"3 {a} {b} {c}" for a, b, c in f]
        )
        + "\r\n"
    )


@pytest.fixture()
def modelnet_root(tmp_path) -> Path:
    root = tmp_path / "ModelNet40"
    v, f = box_mesh()
    write_quirky_off(root / "box/train/box_0001.off", v, f)
    write_quirky_off(root / "box/train/box_0002.off", v * 2.0, f)
    write_quirky_off(root / "box/test/box_0101.off", v, f)
    write_quirky_off(root / "slab/test/slab_0001.off", *box_mesh((3.0, 3.0, 0.5)))
    return root


def small(**kw) -> dict:
    small = dict(
        image=ImageOptions(width=96, height=72, fx=90.0, fy=90.0),
        view=ViewOptions(max_points=300),
        template=TemplateOptions(template_points=300),
    )
    return {**small, **kw}


def test_layout_split_and_category_selection(modelnet_root):
    ds = ModelNet40(str(modelnet_root), split="train", views_per_instance=2, **small())
    assert ds.observation_ids() == ["box/box_0001/v00", "box/box_0001/v01", "box/box_0002/v00", "box/box_0002/v01"]
    test = ModelNet40(str(modelnet_root), split="test", categories=["slab"], views_per_instance=1, **small())
    assert test.observation_ids() == ["slab/slab_0001/v00"]
    assert ds.category_of("box/box_0001/v00") == "box"
    with pytest.raises(DatasetError, match="dataset.split"):
        ModelNet40(str(modelnet_root), split="val").observation_ids()
    with pytest.raises(DatasetError, match="not a folder"):
        ModelNet40(str(modelnet_root / "missing"))


def test_view_is_on_the_normalised_mesh_and_consistent(modelnet_root):
    ds = ModelNet40(str(modelnet_root), split="train", views_per_instance=2, **small())
    obs = ds.observation("box/box_0002/v01")
    v, _ = ds.canonical_mesh("box", "box_0002")
    np.testing.assert_allclose(np.linalg.norm(v, axis=1).max(), 1.0)
    np.testing.assert_allclose(0.5 * (v.min(0) + v.max(0)), 0.0, atol=1e-12)
    half = np.abs(v).max(0)  # the normalised box is [-half, half]
    p_obj = transform_points(obs.T_object_camera, obs.points_camera)
    on_face = np.abs(np.abs(p_obj) - half).min(axis=1)
    assert np.all(np.abs(p_obj) <= half + 1e-4) and np.median(on_face) < 1e-4
    R_camera_object = invert_T(obs.T_object_camera)[:3, :3]
    np.testing.assert_allclose(obs.ground_normal_camera, R_camera_object @ [0, 0, 1], atol=1e-12)
    assert (np.einsum("ij,ij->i", obs.normals_camera, obs.points_camera) < 0).all()  # face the camera
    assert len(obs.points_camera) == 300


def test_views_are_deterministic_in_seed_and_id(modelnet_root):
    a = ModelNet40(str(modelnet_root), split="train", seed=3, **small()).observation("box/box_0001/v01")
    b = ModelNet40(str(modelnet_root), split="train", seed=3, **small()).observation("box/box_0001/v01")
    c = ModelNet40(str(modelnet_root), split="train", seed=4, **small()).observation("box/box_0001/v01")
    np.testing.assert_array_equal(a.points_camera, b.points_camera)
    np.testing.assert_array_equal(a.T_object_camera, b.T_object_camera)
    assert not np.allclose(a.T_object_camera, c.T_object_camera)


def test_templates_from_training_instances_and_instance_model(modelnet_root):
    ds = ModelNet40(
        str(modelnet_root),
        split="test",
        categories=["box"],
        **small(
            template=TemplateOptions(template_points=300, templates={"box": ["box_0001"]}, symmetric={"box": [0, 0, 1]})
        ),
    )
    (t,) = ds.category_templates("box")
    assert t.template_id == "modelnet40/box_0001" and t.points.shape == (300, 3)
    model = ds.instance_model("box", "box_0101")
    np.testing.assert_allclose(model.vertices, t.vertices)  # same shape, same canonical frame
    np.testing.assert_allclose(ds.observation("box/box_0101/v00").symmetry_axis, [0, 0, 1])
    with pytest.raises(DatasetError, match="box_9999"):
        ds.instance_model("box", "box_9999")


def test_uppercase_off_files_are_listed_and_read(modelnet_root):
    (modelnet_root / "box/train/box_0002.off").rename(modelnet_root / "box/train/box_0002.OFF")
    ds = ModelNet40(str(modelnet_root), split="train", views_per_instance=1, **small())
    assert ds.observation_ids() == ["box/box_0001/v00", "box/box_0002/v00"]
    big, small_box = ds.instance_model("box", "box_0002"), ds.instance_model("box", "box_0001")
    np.testing.assert_allclose(big.vertices, small_box.vertices)  # twice the size: the same normalised mesh
    assert len(ds.observation("box/box_0002/v00").points_camera) > 0


def test_a_malformed_off_fails_that_observation_only(modelnet_root):
    (modelnet_root / "box/train/box_0003.off").write_text("OFF\n8 12 0\n1 2 3\n")
    ds = ModelNet40(str(modelnet_root), split="train", views_per_instance=1, **small())
    assert "box/box_0003/v00" in ds.observation_ids()
    with pytest.raises(DatasetError, match="box_0003.off"):
        ds.observation("box/box_0003/v00")
    ds.observation("box/box_0001/v00")


def test_too_small_a_view_raises(modelnet_root):
    ds = ModelNet40(str(modelnet_root), split="train", **small(view=ViewOptions(max_points=300, distance=400.0)))
    with pytest.raises(DatasetError, match="pixels see the object"):
        ds.observation("box/box_0001/v00")


# ----------------------------------------------------------------------------- resampled


@pytest.fixture()
def resampled_root(tmp_path) -> Path:
    """A PointNet++-style folder: a y-up box cloud (4 x 1 x 2 in file x, y, z) with normals."""
    import trimesh

    root = tmp_path / "modelnet40_normal_resampled"
    (root / "box").mkdir(parents=True)
    m = trimesh.creation.box(extents=(4.0, 1.0, 2.0))
    pts, fid = trimesh.sample.sample_surface_even(m, 1500, seed=0)
    nrm = m.face_normals[fid]
    for name, scale in (("box_0001", 1.0), ("box_0002", 0.5)):
        np.savetxt(root / "box" / f"{name}.txt", np.hstack([pts * scale, nrm]), delimiter=",", fmt="%.6f")
    (root / "modelnet40_train.txt").write_text("box_0001\nbox_0002\n")
    (root / "modelnet40_test.txt").write_text("")
    return root


def test_resampled_views_are_visible_subsets_with_the_files_normals(resampled_root):
    ds = ModelNet40Resampled(
        str(resampled_root),
        split="train",
        views_per_instance=2,
        view=ViewOptions(max_points=400),
        template=TemplateOptions(templates={"box": ["box_0001"]}),
    )
    assert ds.observation_ids() == ["box/box_0001/v00", "box/box_0001/v01", "box/box_0002/v00", "box/box_0002/v01"]
    pts, nrm = ds.canonical_cloud("box_0001")
    ext = np.ptp(pts, axis=0)
    np.testing.assert_allclose(ext / ext.max(), [1.0, 0.5, 0.25], atol=0.02)  # y-up file: height 1 -> z
    obs = ds.observation("box/box_0001/v01")
    p_obj = transform_points(obs.T_object_camera, obs.points_camera)
    d = np.linalg.norm(p_obj[:, None] - pts[None], axis=2).min(axis=1)
    assert d.max() < 1e-9  # every observed point is a point of the cloud
    cam = obs.T_object_camera[:3, 3]
    n_obj = obs.normals_camera @ obs.T_object_camera[:3, :3].T
    assert (np.einsum("ij,ij->i", n_obj, cam - p_obj) > 0).all()  # visible faces look at the camera
    # the box's normals are outward; HPR keeps a few grazing back-face points, whose normals flip
    assert obs.info["normals_flipped"] < 0.1 * len(obs.points_camera)
    assert len(obs.points_camera) <= 400
    assert ds.category_templates("box")[0].template_id == "modelnet40_resampled/box_0001"


def test_resampled_bad_files(resampled_root):
    with pytest.raises(DatasetError, match="modelnet40_val.txt"):
        ModelNet40Resampled(str(resampled_root), split="val").observation_ids()
    (resampled_root / "box" / "box_0002.txt").write_text("1,2,3\n4,5,6\n")
    ds = ModelNet40Resampled(str(resampled_root), split="train")
    with pytest.raises(DatasetError, match="box_0002.txt"):
        ds.observation("box/box_0002/v00")


@pytest.mark.data
def test_shared_modelnet40_and_resampled_agree_on_the_object_frame(shared_data):
    from scipy.spatial import cKDTree

    off = ModelNet40(str(shared_data / "ModelNet40"), split="train", **small())
    obs = off.observation("airplane/airplane_0001/v00")
    assert len(obs.points_camera) == 300
    res = ModelNet40Resampled(
        str(shared_data / "modelnet40_normal_resampled"), split="train", view=ViewOptions(max_points=300)
    )
    assert res.observation("chair/chair_0391/v00").points_camera.shape == (300, 3)
    a = off.instance_model("airplane", "airplane_0001").points
    b = res.instance_model("airplane", "airplane_0001").points
    chamfer = cKDTree(b).query(a)[0].mean() + cKDTree(a).query(b)[0].mean()  # symmetric, mean distances
    assert chamfer < 0.08  # same shape in the same frame (measured 0.04)
