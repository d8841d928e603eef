"""The embedded synthetic dataset: shapes, outer-surface clouds, determinism, ground truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from catpose.datasets.meshio import sample_outer_surface
from catpose.datasets.shapes import SHAPES, SYMMETRIC_CATEGORIES
from catpose.datasets.synthetic import SyntheticDataset
from catpose.datasets.views import ImageOptions, ViewOptions
from catpose.errors import ConfigError, DatasetError
from catpose.geometry import invert_T, stable_seed, transform_points

CATEGORIES = ["airplane", "chair", "car", "mug", "bottle", "bowl", "can", "plate"]
# a small, fast configuration (the default config is exercised once, below)
SMALL = dict(
    categories=["chair", "mug", "bowl"],
    instances_per_category=2,
    views_per_instance=2,
    num_templates=1,
    template_points=1024,
    image=ImageOptions(width=160, height=120, fx=150.0, fy=150.0),
    view=ViewOptions(max_points=1024),
)


def mesh_distance(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Exact unsigned distance of (N, 3) points to a triangle mesh (Open3D RaycastingScene)."""
    from catpose.o3d import o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(vertices, np.float32)), o3d.core.Tensor(np.asarray(triangles, np.uint32))
    )
    return scene.compute_distance(o3d.core.Tensor(np.asarray(points, np.float32))).numpy()


@pytest.fixture(scope="module")
def small() -> SyntheticDataset:
    return SyntheticDataset(seed=7, **SMALL)


# ------------------------------------------------------------------ shapes


@pytest.mark.parametrize("category", CATEGORIES)
def test_every_category_builds_normalised(category: str) -> None:
    assert category in SHAPES
    mesh = SHAPES[category](np.random.default_rng(stable_seed("test", category)))
    v = np.asarray(mesh.vertices)
    assert len(mesh.faces) > 20 and np.isfinite(v).all()
    np.testing.assert_allclose(0.5 * (v.min(axis=0) + v.max(axis=0)), 0.0, atol=1e-9)
    assert np.linalg.norm(v, axis=1).max() == pytest.approx(1.0)
    # same generator state, same mesh
    again = SHAPES[category](np.random.default_rng(stable_seed("test", category)))
    np.testing.assert_array_equal(v, again.vertices)


def test_symmetric_categories_are_round() -> None:
    for category in SYMMETRIC_CATEGORIES:
        v = np.asarray(SHAPES[category](np.random.default_rng(1)).vertices)
        # a surface of revolution about z: x and y extents agree
        ext = v.max(axis=0) - v.min(axis=0)
        assert ext[0] == pytest.approx(ext[1], rel=0.02), category


def test_asymmetric_categories_face_plus_x() -> None:
    rng = np.random.default_rng(11)
    for _ in range(5):
        v = np.asarray(SHAPES["airplane"](rng).vertices)
        assert abs(v[np.argmax(v[:, 0]), 1]) < 0.05  # the most forward point is the nose, on the axis
        v = np.asarray(SHAPES["chair"](rng).vertices)
        assert v[v[:, 2] > 0.6, 0].mean() < 0.0  # the back (top part) is at -x
        v = np.asarray(SHAPES["car"](rng).vertices)
        assert v[v[:, 2] > v[:, 2].max() - 0.05, 0].mean() < 0.0  # the roof is set back from the hood
        v = np.asarray(SHAPES["mug"](rng).vertices)
        rim_x = v[v[:, 2] > v[:, 2].max() - 1e-6, 0].mean()  # the top rim ring is centred on the cup axis
        assert v[:, 0].max() - rim_x > rim_x - v[:, 0].min() + 0.1  # the handle sticks out along +x


def test_outer_surface_sampling_drops_interior_faces_of_concatenated_parts() -> None:
    outer = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    inner = trimesh.creation.box(extents=(0.4, 0.4, 0.4))  # fully hidden inside
    mesh = trimesh.util.concatenate([outer, inner])
    points, normals = sample_outer_surface(mesh.vertices, mesh.faces, 500, np.random.default_rng(0))
    assert len(points) == 500
    assert (np.abs(points).max(axis=1) > 0.5 - 1e-6).all()  # all on the outer box
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert (np.einsum("ij,ij->i", normals, points) > 0).all()  # outward
    again, _ = sample_outer_surface(mesh.vertices, mesh.faces, 500, np.random.default_rng(0))
    np.testing.assert_array_equal(points, again)


# ------------------------------------------------------------------ dataset


def test_ids_are_fixed_and_parseable(small: SyntheticDataset) -> None:
    ids = small.observation_ids()
    assert ids[:3] == ["chair/000/v00", "chair/000/v01", "chair/001/v00"] and len(ids) == 12
    assert all(small.category_of(i) == i.split("/")[0] for i in ids)
    with pytest.raises(DatasetError, match="chair/009/v00"):
        small.observation("chair/009/v00")
    with pytest.raises(DatasetError, match="car/000/v00"):
        small.observation("car/000/v00")  # category not configured


def test_unknown_category_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="sofa.*airplane"):
        SyntheticDataset(categories=["chair", "sofa"])
    with pytest.raises(ConfigError, match="sofa"):
        SyntheticDataset(categories=["chair"]).category_templates("sofa")


def test_same_seed_is_bit_identical_and_order_free(small: SyntheticDataset) -> None:
    a, b = "chair/001/v01", "bowl/000/v00"
    other = SyntheticDataset(seed=7, **SMALL)
    ob = other.observation(b)  # B first, then A, on a fresh dataset
    oa = other.observation(a)
    for fresh, ref in ((oa, small.observation(a)), (ob, small.observation(b))):
        assert fresh.points_camera.tobytes() == ref.points_camera.tobytes()
        assert fresh.normals_camera.tobytes() == ref.normals_camera.tobytes()
        assert fresh.T_object_camera.tobytes() == ref.T_object_camera.tobytes()
        assert fresh.ground_normal_camera.tobytes() == ref.ground_normal_camera.tobytes()
    t_other, t_small = other.category_templates("mug")[0], small.category_templates("mug")[0]
    assert t_other.points.tobytes() == t_small.points.tobytes()

    different = SyntheticDataset(seed=8, **SMALL).observation(a)
    assert not np.array_equal(different.T_object_camera, oa.T_object_camera)
    assert different.points_camera.shape != oa.points_camera.shape or not np.array_equal(
        different.points_camera, oa.points_camera
    )


def test_instances_differ_from_each_other_and_from_templates(small: SyntheticDataset) -> None:
    for category in small.categories:
        models = [
            small.instance_model(category, "000"),
            small.instance_model(category, "001"),
            *small.category_templates(category),
        ]
        assert [m.template_id for m in models] == [
            f"synthetic/{category}/000",
            f"synthetic/{category}/001",
            f"synthetic/{category}/t0",
        ]
        for i, a in enumerate(models):
            # a model's own cloud lies on its mesh ...
            assert mesh_distance(a.points, a.vertices, a.triangles).max() < 1e-4
            for b in models[i + 1 :]:
                # ... while another instance's is clearly off it (symmetric mean distance)
                d = 0.5 * (
                    mesh_distance(a.points, b.vertices, b.triangles).mean()
                    + mesh_distance(b.points, a.vertices, a.triangles).mean()
                )
                assert d > 0.005, (a.template_id, b.template_id, d)


def test_ground_truth_is_consistent(small: SyntheticDataset) -> None:
    for obs_id in small.observation_ids():
        obs = small.observation(obs_id)
        model = small.instance_model(obs.category, obs.instance_id)
        assert obs.points_camera.shape == obs.normals_camera.shape and 50 <= len(obs.points_camera) <= 1024
        T_camera_object = invert_T(obs.T_object_camera)
        # ground normal = R_camera_object @ z
        np.testing.assert_allclose(obs.ground_normal_camera, T_camera_object[:3, :3] @ [0.0, 0.0, 1.0], atol=1e-12)
        # observed points land on the instance: exactly on its mesh, near its complete cloud
        points_object = transform_points(obs.T_object_camera, obs.points_camera)
        assert mesh_distance(points_object, model.vertices, model.triangles).max() < 1e-4
        nn, _ = cKDTree(model.points).query(points_object)
        assert np.median(nn) < 0.05 and np.quantile(nn, 0.95) < 0.1, obs_id
        # normals are unit and face the camera (at the origin)
        np.testing.assert_allclose(np.linalg.norm(obs.normals_camera, axis=1), 1.0, atol=1e-9)
        assert (np.einsum("ij,ij->i", obs.normals_camera, -obs.points_camera) >= 0).all()
        expected_axis = [0.0, 0.0, 1.0] if obs.category in SYMMETRIC_CATEGORIES else None
        if expected_axis is None:
            assert obs.symmetry_axis is None
        else:
            np.testing.assert_array_equal(obs.symmetry_axis, expected_axis)


def test_noise_options() -> None:
    kw = dict(SMALL, categories=["chair"], instances_per_category=1, views_per_instance=1)
    clean = SyntheticDataset(seed=3, **kw).observation("chair/000/v00")
    noisy_ds = SyntheticDataset(
        seed=3, ground_normal_noise_deg=5.0, **dict(kw, view=ViewOptions(max_points=1024, depth_noise_std=0.01))
    )
    noisy = noisy_ds.observation("chair/000/v00")
    np.testing.assert_array_equal(noisy.T_object_camera, clean.T_object_camera)  # same view
    assert noisy.points_camera.tobytes() == noisy_ds.observation("chair/000/v00").points_camera.tobytes()
    model = noisy_ds.instance_model("chair", "000")
    off = mesh_distance(transform_points(noisy.T_object_camera, noisy.points_camera), model.vertices, model.triangles)
    assert 0.002 < np.median(off) < 0.03
    angle = np.rad2deg(np.arccos(np.clip(noisy.ground_normal_camera @ clean.ground_normal_camera, -1, 1)))
    assert 0.0 < angle < 25.0
    assert np.linalg.norm(noisy.ground_normal_camera) == pytest.approx(1.0)


def test_empty_view_is_a_dataset_error() -> None:
    far = SyntheticDataset(
        seed=0,
        categories=["can"],
        instances_per_category=1,
        views_per_instance=1,
        num_templates=0,
        template_points=256,
        image=ImageOptions(width=16, height=12, fx=10.0, fy=10.0),
        view=ViewOptions(distance=20.0),
    )
    with pytest.raises(DatasetError, match="can/000/v00"):
        far.observation("can/000/v00")


def test_fov_sets_the_focal_length() -> None:
    ds = SyntheticDataset(image=ImageOptions(width=200, height=100, fov_deg=90.0), categories=["can"])
    assert ds.camera.fx == pytest.approx(100.0) and ds.camera.fy == pytest.approx(100.0)
    assert (ds.camera.cx, ds.camera.cy) == (99.5, 49.5)


def test_default_config_composes_and_every_observation_loads(repo_root: Path) -> None:
    from omegaconf import OmegaConf

    from catpose.bench.run.build import build_from_config

    cfg = OmegaConf.create({"seed": 0, "dataset": OmegaConf.load(repo_root / "configs/dataset/synthetic.yaml")})
    name, ds = build_from_config(cfg.dataset, "dataset")
    assert name == "synthetic"
    assert isinstance(ds, SyntheticDataset) and ds.seed == 0
    assert sorted(ds.categories) == sorted(CATEGORIES)
    ids = ds.observation_ids()
    assert len(set(ids)) == len(ids) and 8 <= len(ids) <= 48
    for obs_id in ids:
        obs = ds.observation(obs_id)
        assert len(obs.points_camera) >= 50, obs_id
    templates = ds.category_templates("chair")
    assert len(templates) == ds.num_templates and all(t.template_id.startswith("synthetic/chair/t") for t in templates)
