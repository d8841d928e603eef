"""The cluttered synthetic set (dataset=clutter): layout, rendering, BOP files, determinism, split."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from catpose.bench.real.split import load_split
from catpose.datasets.clutter import Clutter, clutter_root, generate
from catpose.datasets.clutter_layout import ClutterSpec, footprint, layout_scene, polygons_overlap
from catpose.datasets.clutter_render import render_scene
from catpose.datasets.render import PinholeCamera, render_depth
from catpose.errors import ConfigError
from catpose.geometry import apply_R, compose_T
from catpose.raycast import RayCaster
from catpose.resting import resting_ups


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """A BOP dataset folder with two small models in mm: a box (obj 1) and a cylinder (obj 2)."""
    root = tmp_path_factory.mktemp("bop")
    (root / "models").mkdir()
    trimesh.creation.box(extents=[60.0, 40.0, 90.0]).export(root / "models" / "obj_000001.ply")
    trimesh.creation.cylinder(radius=30.0, height=80.0, sections=24).export(root / "models" / "obj_000002.ply")
    (root / "models" / "models_info.json").write_text(
        json.dumps(
            {
                "1": {"diameter": 118.0},
                "2": {"diameter": 110.0, "symmetries_continuous": [{"axis": [0, 0, 1], "offset": [0, 0, 0]}]},
            }
        )
    )
    return root


def _spec(**kw) -> ClutterSpec:
    base = dict(
        num_scenes=4,
        obj_ids=(1, 2),
        objects_per_scene=(2, 2),
        width=160,
        height=120,
        K=((300.0, 0.0, 79.5), (0.0, 300.0, 59.5), (0.0, 0.0, 1.0)),
        distance_mm=(500.0, 600.0),
    )
    return ClutterSpec(**{**base, **kw})


def _meshes(models):
    from catpose.datasets.meshio import read_mesh

    return {o: read_mesh(models / "models" / f"obj_{o:06d}.ply") for o in (1, 2)}


def test_layout_rests_objects_on_the_table_without_overlap(models):
    meshes = _meshes(models)
    rests = {o: resting_ups(v) for o, (v, _) in meshes.items()}
    for scene in range(4):
        layout = layout_scene(_spec(), scene, {o: v for o, (v, _) in meshes.items()}, rests)
        shapes = []
        for obj in layout.objects:
            v = apply_R(obj.T_world_model[:3, :3], meshes[obj.obj_id][0]) + obj.T_world_model[:3, 3]
            assert v[:, 2].min() == pytest.approx(0.0, abs=1e-6)  # standing on the table z = 0
            shapes.append(footprint(v[:, :2]))
        for a in range(len(shapes)):
            for b in range(a + 1, len(shapes)):
                assert not polygons_overlap(shapes[a], shapes[b])
        # the same scene id gives the same scene
        again = layout_scene(_spec(), scene, {o: v for o, (v, _) in meshes.items()}, rests)
        assert all(np.array_equal(p.T_world_model, q.T_world_model) for p, q in zip(layout.objects, again.objects))


def test_rendered_masks_match_a_full_image_rendering(models):
    meshes = _meshes(models)
    spec = _spec(sensor="none")
    layout = layout_scene(
        spec, 1, {o: v for o, (v, _) in meshes.items()}, {o: resting_ups(v) for o, (v, _) in meshes.items()}
    )
    image = render_scene(spec, layout, {o: RayCaster(v, f) for o, (v, f) in meshes.items()})
    cam = PinholeCamera.from_K(np.asarray(spec.K), spec.width, spec.height)
    for obj, full in zip(layout.objects, image.full):
        v, f = meshes[obj.obj_id]
        ref = render_depth(v, f, compose_T(layout.T_camera_world, obj.T_world_model), cam)
        assert np.array_equal(full, ref > 0)
    # the visible masks partition the object pixels of the scene: no pixel belongs to two objects
    assert (np.sum(image.visible, axis=0) <= 1).all()


def test_generated_files_are_bop_and_deterministic(models, tmp_path):
    spec = _spec()
    root = generate(spec, models / "models", [0, 2], cache_dir=tmp_path / "a", log=lambda m: None)
    again = generate(spec, models / "models", [0, 2], cache_dir=tmp_path / "b", log=lambda m: None)
    assert root.name == again.name == clutter_root(spec, models / "models", tmp_path / "a").name
    for scene in ("000000", "000002"):
        for rel in (
            "depth/000000.png",
            "scene_gt.json",
            "scene_gt_info.json",
            "scene_camera.json",
            "mask_visib/000000_000000.png",
        ):
            assert (root / "test" / scene / rel).read_bytes() == (again / "test" / scene / rel).read_bytes()
    assert not (root / "test" / "000001").exists()  # only what was asked for
    info = json.loads((root / "test" / "000000" / "scene_gt_info.json").read_text())["0"]
    assert all(0.0 <= x["visib_fract"] <= 1.0 for x in info)
    # another setting, another folder
    assert clutter_root(_spec(scene_seed=1), models / "models", tmp_path / "a") != root


def test_the_bop_loader_reads_the_set_with_depth_images(models, tmp_path):
    ds = Clutter(
        str(models),
        cache_dir=str(tmp_path),
        spec=_spec(),
        scenes=[0, 1],
        categories={1: "box", 2: "can"},
        min_visible_pixels=20,
        min_visib_fract=0.0,
    )
    ids = ds.observation_ids()
    assert ids and {int(i.split("/")[1]) for i in ids} <= {0, 1}
    obs = ds.observation(ids[0])
    di = obs.depth_image
    assert di is not None and di.mask.sum() > 0 and di.depth.shape == (120, 160)
    # the depth image is in the object unit of the points: the masked pixels back-project onto them
    from catpose.datasets.render import depth_to_points

    pts, _ = depth_to_points(di.depth, PinholeCamera.from_K(di.K, 160, 120), di.mask)
    assert (
        np.abs(np.sort(pts[:, 2])[len(pts) // 2] - np.sort(obs.points_camera[:, 2])[len(obs.points_camera) // 2]) < 0.05
    )


def test_bad_settings_fail_in_one_line(models, tmp_path):
    with pytest.raises(ConfigError, match="objects_per_scene"):
        _spec(objects_per_scene=(3, 2))
    with pytest.raises(ConfigError, match="dataset.root"):
        Clutter(str(tmp_path), cache_dir=str(tmp_path))
    with pytest.raises(ConfigError, match="dataset.scenes"):
        Clutter(str(models), cache_dir=str(tmp_path), spec=_spec(objects_per_scene=(1, 2)), scenes=[7])


def test_split_files_name_disjoint_parts():
    for name in ("clutter", "ycbv"):
        split = load_split(name)
        for choose, report in split.folds:
            assert not set(split.scene_ids(choose)) & set(split.scene_ids(report))
    clutter = load_split("clutter")
    assert clutter.sample_ids("dev", ["can/000003/000000/1", "can/000150/000000/0|2"]) == ["can/000003/000000/1"]
    assert clutter.role("report") == "report A"
    ycbv = load_split("ycbv")
    assert ycbv.role("scene1") == "choose A, report B"


def test_a_split_whose_folds_overlap_is_refused(tmp_path):
    (tmp_path / "bad.yaml").write_text(
        "dataset: x\nparts:\n  a: [[0, 5]]\n  b: [[5, 9]]\nfolds:\n  - {choose: a, report: b}\n"
    )
    with pytest.raises(ConfigError, match="share scenes"):
        load_split("bad", tmp_path)


def test_uniform_resting_draws_each_class_alike(models):
    """resting=uniform: the cylinder (symmetric about z) lies upright, upside down and on its side
    a third of the time each; the box rests on each of its six faces alike. resting=drop follows
    the drop test (the cylinder mostly on its side)."""
    meshes = _meshes(models)
    verts = {o: v for o, (v, _) in meshes.items()}
    rests = {o: resting_ups(v) for o, v in verts.items()}
    axes = {1: None, 2: np.array([0.0, 0.0, 1.0])}

    def classes(spec) -> dict[int, list]:
        out: dict[int, list] = {1: [], 2: []}
        for scene in range(150):
            for obj in layout_scene(spec, scene, verts, rests, axes).objects:
                u = np.round(obj.rest_up, 3)
                out[obj.obj_id].append(int(np.sign(u[2])) if obj.obj_id == 2 else tuple(u))
        return out

    uniform = classes(_spec(num_scenes=150))
    can = np.bincount(np.asarray(uniform[2]) + 1, minlength=3) / len(uniform[2])  # down, side, up
    assert np.abs(can - 1 / 3).max() < 0.12, can
    faces = {u: uniform[1].count(u) / len(uniform[1]) for u in set(uniform[1])}
    assert len(faces) == 6 and max(abs(f - 1 / 6) for f in faces.values()) < 0.08, faces
    drop = classes(_spec(num_scenes=150, resting="drop"))
    assert np.mean(np.asarray(drop[2]) == 0) > 0.6  # the drop test puts a cylinder on its side


def test_the_measured_effects_are_drawn_per_scene_and_reproducible(models):
    """dropout patches take a drawn share of each object's pixels, the segmentation is shifted
    against the depth, and the written truth is off the rendered pose by the drawn spread."""
    from catpose.datasets.clutter_render import scene_effects

    spec = _spec(dropout_blobs=(0.2, 0.2), mask_shift_px=(2.0, 2.0), annotation_mm=(1.0, 1.0), annotation_deg=(0, 0))
    depth = np.full((120, 160), 0.8)
    visible = [np.zeros((120, 160), bool)]
    visible[0][30:90, 40:120] = True
    runs = [scene_effects(spec, np.random.default_rng(5), depth, visible, [m.copy() for m in visible]) for _ in "ab"]
    (d, masks, ann), (d2, masks2, ann2) = runs
    assert np.array_equal(d, d2) and np.array_equal(masks[0], masks2[0]) and np.array_equal(ann[0], ann2[0])
    lost = (d == 0) & visible[0]
    assert lost.sum() / visible[0].sum() == pytest.approx(0.2, abs=0.01) and not ((d == 0) & ~visible[0]).any()
    rows, cols = np.nonzero(masks[0])
    shift = np.hypot(rows.mean() - 59.5, cols.mean() - 79.5)
    assert 1.0 <= shift <= 3.0 and masks[0].sum() == visible[0].sum()
    assert ann[0][:3, :3] == pytest.approx(np.eye(3)) and 0 < np.linalg.norm(ann[0][:3, 3]) < 6.0


def test_a_split_by_object_filters_rows_by_their_obj_id():
    split = load_split("clutter_objects")
    rows = [
        {"sample_id": "can/000003/000000/1", "info": {"obj_id": 1}},
        {"sample_id": "mug/000003/000000/2", "info": {"obj_id": 14}},
        {"sample_id": "can/000150/000000/0", "info": {"obj_id": 6}},
    ]
    assert split.row_ids("dev_A", rows) == ["can/000003/000000/1"]
    assert split.row_ids("dev_B", rows) == ["mug/000003/000000/2"]
    assert split.row_ids("report_A", rows) == ["can/000150/000000/0"] and split.row_ids("report_B", rows) == []
    assert split.role("report_B") == "report A" and split.role("dev_B") == "choose B"
    with pytest.raises(ConfigError, match="obj_id"):
        split.sample_ids("dev_A", ["can/000003/000000/1"])
