"""BOP loader on a scene rendered here (a box and a cylinder on a table, written as a 16-bit mm
depth PNG with scene_gt/scene_camera/models_info JSON files) and on the shared TYO-L frame."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from catpose.datasets.bop import BOP
from catpose.datasets.depthio import fit_ground_plane
from catpose.datasets.render import PinholeCamera, render_depth
from catpose.datasets.templates import TemplateOptions
from catpose.errors import ConfigError, DatasetError
from catpose.geometry import invert_T, look_at_T_camera_world, make_T, transform_points

CAMERA = PinholeCamera(320, 240, 300.0, 300.0, 159.5, 119.5)
BOX = (100.0, 60.0, 40.0)  # mm; obj 1 stands on z = 0 of its model frame
CYL_AT = np.array([150.0, 0.0, 0.0])  # obj 2 (cylinder, radius 30, height 80) placement on the table
T_CAMERA_WORLD = look_at_T_camera_world(
    np.array([350.0, -450.0, 500.0]), np.array([60.0, 0.0, 20.0]), np.array([0.0, 0.0, 1.0])
)


def models() -> dict[int, tuple[np.ndarray, np.ndarray]]:
    import trimesh

    box = trimesh.creation.box(extents=BOX)
    box.apply_translation([0, 0, BOX[2] / 2])
    cyl = trimesh.creation.cylinder(radius=30.0, height=80.0, sections=48)
    cyl.apply_translation([0, 0, 40.0])
    return {1: (np.asarray(box.vertices), np.asarray(box.faces)), 2: (np.asarray(cyl.vertices), np.asarray(cyl.faces))}


def T_camera_model(obj_id: int) -> np.ndarray:
    return T_CAMERA_WORLD @ make_T(np.eye(3), CYL_AT if obj_id == 2 else np.zeros(3))


def write_png16(path: Path, depth_mm: np.ndarray) -> None:
    from PIL import Image

    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.round(depth_mm).astype(np.uint16)).save(path)


@pytest.fixture()
def bop_root(tmp_path) -> Path:
    import trimesh

    root = tmp_path / "bop"
    (root / "models").mkdir(parents=True)
    ms = models()
    for obj_id, (v, f) in ms.items():
        trimesh.Trimesh(v, f, process=False).export(root / "models" / f"obj_{obj_id:06d}.ply")
    shutil.copy(root / "models/obj_000001.ply", root / "models/obj_000003.ply")
    (root / "models/models_info.json").write_text(
        json.dumps(
            {
                "1": {"diameter": 124.0},
                "2": {"diameter": 100.0, "symmetries_continuous": [{"axis": [0, 0, 1], "offset": [0, 0, 0]}]},
                "3": {"diameter": 124.0},
            }
        )
    )
    # the scene: a 2 m table at z = 0 with both objects on it
    table_v = np.array([[-1000, -1000, 0], [1000, -1000, 0], [1000, 1000, 0], [-1000, 1000, 0]], float)
    parts = [(table_v, np.array([[0, 1, 2], [0, 2, 3]]))] + [
        (transform_points(make_T(np.eye(3), CYL_AT if k == 2 else np.zeros(3)), v), f) for k, (v, f) in ms.items()
    ]
    verts, tris, off = [], [], 0
    for v, f in parts:
        verts.append(v)
        tris.append(f + off)
        off += len(v)
    depth = render_depth(np.concatenate(verts), np.concatenate(tris), T_CAMERA_WORLD, CAMERA)
    scene = root / "test" / "000001"
    write_png16(scene / "depth" / "000000.png", depth)

    def gt(obj_id: int, T: np.ndarray) -> dict:
        return {"obj_id": obj_id, "cam_R_m2c": T[:3, :3].ravel().tolist(), "cam_t_m2c": T[:3, 3].tolist()}

    far = make_T(np.eye(3), [5000.0, 0.0, 1000.0])  # obj 3: outside the image
    (scene / "scene_gt.json").write_text(
        json.dumps(
            {
                "0": [gt(1, T_camera_model(1)), gt(2, T_camera_model(2)), gt(3, far), gt(4, T_camera_model(1))],
                "1": [gt(1, T_camera_model(1))],
            }
        )
    )  # image 1 has no depth file: not listed
    cam = {"cam_K": CAMERA.K.ravel().tolist(), "depth_scale": 1.0}
    (scene / "scene_camera.json").write_text(json.dumps({"0": cam, "1": cam}))
    return root


CATS = {1: "box", 2: "can", 3: "box"}


def test_ground_plane_fit_is_exact_on_a_plane_with_clutter_and_deterministic():
    rng = np.random.default_rng(0)
    up = np.array([0.2, -0.9, -0.3])
    up /= np.linalg.norm(up)
    e1 = np.cross(up, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    origin = -2.0 * up  # the plane lies 2 units from the camera, which sees it from the +up side
    plane = origin + rng.uniform(-1, 1, (3000, 1)) * e1 + rng.uniform(-1, 1, (3000, 1)) * e2
    clutter = rng.uniform(-1, 1, (1500, 3))
    pts = np.concatenate([plane, clutter])
    n, d, count = fit_ground_plane(pts, 0.01, 200, seed=5)
    np.testing.assert_allclose(n, up, atol=1e-9)
    assert d == pytest.approx(2.0) and 3000 <= count < 3100
    n2, d2, _ = fit_ground_plane(pts, 0.01, 200, seed=5)
    np.testing.assert_array_equal(n, n2)


def test_ids_skip_unlisted_objects_and_missing_frames(bop_root):
    ds = BOP(str(bop_root), categories=CATS)
    assert ds.observation_ids() == ["box/000001/000000/0", "can/000001/000000/1", "box/000001/000000/2"]
    everything = BOP(str(bop_root))
    assert everything.observation_ids()[-1] == "obj_000004/000001/000000/3"


def test_rendered_frame_round_trips_the_ground_truth_pose(bop_root):
    ds = BOP(str(bop_root), categories=CATS, max_points=0)
    obs = ds.observation("box/000001/000000/0")
    assert obs.info["mask_source"] == "render" and obs.instance_id == "obj_000001"
    R_obj_model, centre, scale = ds.normalisation(1)
    np.testing.assert_allclose(centre, [0, 0, 20.0], atol=1e-9)
    np.testing.assert_allclose(scale, np.linalg.norm(np.asarray(BOX) / 2), rtol=1e-9)
    # independent expectation: object frame = model frame shifted by -centre and divided by scale
    T_object_model = make_T(R_obj_model, -centre) / 1.0
    T_object_model[:3] /= scale
    T_object_model[3] = [0, 0, 0, 1]
    S = np.diag([scale, scale, scale, 1.0])  # normalised camera points -> mm
    expected = T_object_model @ invert_T(T_camera_model(1)) @ S
    np.testing.assert_allclose(obs.T_object_camera, expected, atol=1e-9)
    # every observed point lies on the box surface (depth is quantised to 1 mm)
    p_model = transform_points(invert_T(T_camera_model(1)), obs.points_camera * scale)
    half = np.asarray(BOX) / 2
    q = np.abs(p_model - [0, 0, 20.0])
    assert np.all(q <= half + 2.0)
    assert np.percentile(np.abs(q - half).min(axis=1), 95) < 2.0
    # ground normal from the table = the model's up axis in the camera frame
    up = T_camera_model(1)[:3, 2]
    assert np.degrees(np.arccos(obs.ground_normal_camera @ up)) < 2.0
    assert obs.symmetry_axis is None and obs.info["ground_vs_object_up_deg"] < 2.0


def test_symmetry_from_models_info_and_category_override(bop_root):
    ds = BOP(str(bop_root), categories=CATS, max_points=500)
    np.testing.assert_allclose(ds.observation("can/000001/000000/1").symmetry_axis, [0, 0, 1])
    assert ds.instance_model("can", "obj_000002").symmetry_axis is not None
    over = BOP(str(bop_root), categories=CATS, template=TemplateOptions(symmetric={"box": [1, 0, 0]}))
    np.testing.assert_allclose(over.symmetry_axis(1, "box"), [1, 0, 0])


def test_mask_visib_is_used_when_present(bop_root):
    from PIL import Image

    ds = BOP(str(bop_root), categories=CATS)
    depth = np.asarray(Image.open(bop_root / "test/000001/depth/000000.png")).astype(float)
    v, f = models()[1]
    rendered = render_depth(v, f, T_camera_model(1), CAMERA)
    mask = (rendered > 0) & (np.abs(depth - rendered) < 5)
    (bop_root / "test/000001/mask_visib").mkdir()
    Image.fromarray((mask * 255).astype(np.uint8)).save(bop_root / "test/000001/mask_visib/000000_000000.png")
    obs = ds.observation("box/000001/000000/0")
    assert obs.info["mask_source"] == "mask_visib" and obs.info["visible_pixels"] == int((mask & (depth > 0)).sum())
    with pytest.raises(DatasetError, match="000000_000001.png"):
        BOP(str(bop_root), categories=CATS, mask="mask_visib").observation("can/000001/000000/1")


def test_templates_from_mesh_files_and_models(bop_root):
    ds = BOP(
        str(bop_root),
        categories=CATS,
        template=TemplateOptions(
            template_points=200, templates={"box": ["obj_000001", {"path": "models/obj_000002.ply", "up": "+z"}]}
        ),
    )
    a, b = ds.category_templates("box")
    assert a.template_id == "bop/obj_000001" and b.template_id == "box/obj_000002"
    np.testing.assert_allclose(np.linalg.norm(a.vertices, axis=1).max(), 1.0)


def test_bad_input_raises_one_line_dataset_errors(bop_root):
    ds = BOP(str(bop_root), categories=CATS)
    with pytest.raises(DatasetError, match="visible pixels"):
        ds.observation("box/000001/000000/2")
    with pytest.raises(DatasetError, match="not in dataset.categories"):
        ds.observation("box/000001/000000/3")
    with pytest.raises(DatasetError, match="obj_000009.ply"):
        ds.instance_model("box", "obj_000009")
    with pytest.raises(DatasetError, match="split folder"):
        BOP(str(bop_root), split="val").observation_ids()
    with pytest.raises(DatasetError, match="not a folder"):
        BOP(str(bop_root / "nope"))

    from PIL import Image

    depth_path = bop_root / "test/000001/depth/000000.png"
    Image.fromarray(np.zeros((240, 320), np.uint8)).save(depth_path)
    with pytest.raises(DatasetError, match="000000.png is uint8") as info:
        BOP(str(bop_root), categories=CATS).observation("box/000001/000000/0")
    assert "\n" not in str(info.value)

    (bop_root / "test/000001/scene_gt.json").write_text("{not json")
    with pytest.raises(DatasetError, match="scene_gt.json is not valid JSON"):
        BOP(str(bop_root), categories=CATS).observation_ids()


@pytest.mark.data
def test_shared_tyol_frame(shared_data):
    ds = BOP(str(shared_data / "bop" / "tyol"), categories={19: "basket"}, max_points=1000)
    assert ds.observation_ids() == ["basket/000019/000010/0"]
    obs = ds.observation("basket/000019/000010/0")
    assert obs.info["mask_source"] == "render" and obs.info["visible_pixels"] > 5000
    assert obs.info["ground_vs_object_up_deg"] < 10.0  # measured 5.4: the basket stands on the table
    model = ds.instance_model("basket", "obj_000019")
    from scipy.spatial import cKDTree

    d, _ = cKDTree(model.points).query(transform_points(obs.T_object_camera, obs.points_camera))
    assert np.median(d) < 0.05  # object unit: the masked points lie on the model at the GT pose


def test_discrete_symmetries_map_the_normalised_model_onto_itself(bop_root):
    info_path = bop_root / "models/models_info.json"
    info = json.loads(info_path.read_text())
    S_model = make_T(np.diag([-1.0, -1.0, 1.0]), [0.0, 0.0, 0.0])  # the box turned 180 degrees about z
    info["1"]["symmetries_discrete"] = [S_model.ravel().tolist()]
    info_path.write_text(json.dumps(info))
    ds = BOP(str(bop_root), categories=CATS)
    (S,) = ds.discrete_symmetries(1)
    v = ds.instance_model("box", "obj_000001").vertices
    moved = transform_points(S, v)
    dist = np.linalg.norm(moved[:, None] - v[None], axis=2).min(axis=1)
    assert dist.max() < 1e-9 and np.allclose(S[:3, :3] @ S[:3, :3].T, np.eye(3))
    assert len(ds.observation("box/000001/000000/0").symmetries) == 1
    info["1"]["symmetries_discrete"] = [[1, 2, 3]]
    info_path.write_text(json.dumps(info))
    with pytest.raises(DatasetError, match="symmetries_discrete"):
        BOP(str(bop_root), categories=CATS).discrete_symmetries(1)


def _observed(ds: BOP, obs_id: str) -> np.ndarray:
    return np.asarray(ds.observation(obs_id).points_camera)


def test_models_eval_tif_depth_and_sensor_layouts_read_the_same_frame(bop_root, tmp_path):
    from PIL import Image

    ref = BOP(str(bop_root), categories=CATS)
    ids = ref.observation_ids()
    root = tmp_path / "h3"
    shutil.copytree(bop_root, root)
    shutil.move(root / "models", root / "models_eval")
    scene = root / "test" / "000001"
    for name in ("scene_gt", "scene_camera"):
        shutil.move(scene / f"{name}.json", scene / f"{name}_cam1.json")
    (scene / "depth_cam1").mkdir()
    depth = np.asarray(Image.open(scene / "depth" / "000000.png"))
    Image.fromarray(depth.astype(np.uint16)).save(scene / "depth_cam1" / "000000.tif")
    shutil.rmtree(scene / "depth")
    ds = BOP(str(root), categories=CATS, models_dir="models_eval", depth_ext=".tif", sensor="cam1")
    assert ds.observation_ids() == ids
    np.testing.assert_allclose(_observed(ds, ids[0]), _observed(ref, ids[0]))
    with pytest.raises(DatasetError, match="does not exist"):  # the classic layout is not there any more
        BOP(str(root), categories=CATS).observation_ids()
    with pytest.raises(DatasetError, match="depth_ext"):
        BOP(str(root), categories=CATS, depth_ext=".jpg")


def test_visib_fract_and_test_targets_filters(bop_root):
    scene = bop_root / "test" / "000001"
    all_ids = BOP(str(bop_root), categories=CATS).observation_ids()
    assert all_ids == ["box/000001/000000/0", "can/000001/000000/1", "box/000001/000000/2"]
    (scene / "scene_gt_info.json").write_text(
        json.dumps({"0": [{"visib_fract": 0.9}, {"visib_fract": 0.6}, {"visib_fract": 0.0}, {"visib_fract": 0.9}]})
    )
    ds = BOP(str(bop_root), categories=CATS)
    assert ds.observation_ids() == all_ids[:2]
    assert any("visib_fract >= 0.1 (1 instances left out)" in f for f in ds.filters)
    assert BOP(str(bop_root), categories=CATS, min_visib_fract=0).observation_ids() == all_ids
    (bop_root / "test_targets_bop19.json").write_text(
        json.dumps([{"scene_id": 1, "im_id": 0, "obj_id": 2, "inst_count": 1}])
    )
    ds = BOP(str(bop_root), categories=CATS)
    assert ds.observation_ids() == ["can/000001/000000/1"]
    assert any("test_targets_bop19.json" in f for f in ds.filters)
    assert BOP(str(bop_root), categories=CATS, targets=None, min_visib_fract=0).observation_ids() == all_ids


def test_unmapped_object_ids_are_named(bop_root):
    with pytest.raises(DatasetError, match=r"object ids \[1, 2, 3, 4\]"), pytest.warns(UserWarning, match="99"):
        BOP(str(bop_root), categories={99: "mug"}).observation_ids()


def test_continuous_symmetry_origin_uses_every_axis_and_offset():
    from catpose.datasets.bop_layout import continuous_symmetry_origin

    one = continuous_symmetry_origin([{"axis": [0, 0, 2], "offset": [5, -3, 0]}], np.array([0.0, 0.0, 40.0]))
    np.testing.assert_allclose(one, [5, -3, 40])
    two = continuous_symmetry_origin(
        [{"axis": [0, 0, 1], "offset": [5, -3, 0]}, {"axis": [1, 0, 0], "offset": [0, -3, 7]}], np.zeros(3)
    )
    np.testing.assert_allclose(two, [5, -3, 7], atol=1e-9)  # where the two axes cross
    assert continuous_symmetry_origin([], np.zeros(3)) is None


def test_object_centre_lies_on_the_offset_symmetry_axis(bop_root):
    """A spin about the (offset) axis must keep the normalised object's origin in place."""
    import trimesh

    info_path = bop_root / "models/models_info.json"
    info = json.loads(info_path.read_text())
    cyl = trimesh.creation.cylinder(radius=30.0, height=80.0, sections=48)
    handle = trimesh.creation.box(extents=(5, 5, 5))
    handle.apply_translation([-40.0, 0, 0])  # shifts the bounding-box centre off the axis
    mesh = trimesh.util.concatenate([cyl, handle])
    mesh.apply_translation([7.0, 4.0, 40.0])
    mesh.export(bop_root / "models" / "obj_000002.ply")
    info["2"]["symmetries_continuous"] = [{"axis": [0, 0, 1], "offset": [7.0, 4.0, 0.0]}]
    info_path.write_text(json.dumps(info))
    ds = BOP(str(bop_root), categories=CATS)
    R, centre, scale = ds.normalisation(2)
    np.testing.assert_allclose((R.T @ centre)[:2], [7.0, 4.0], atol=1e-9)
    v = (ds.model_mm(2)[0] @ R.T - centre) / scale
    assert np.linalg.norm(v, axis=1).max() == pytest.approx(1.0)


def test_unseen_configured_ids_warn_with_the_ids_the_frames_show(bop_root):
    with pytest.warns(
        UserWarning, match=r"object ids \[7\] that no frame shows; the frames show object ids \[1, 2, 3, 4\]"
    ):
        ds = BOP(str(bop_root), categories={1: "box", 7: "mug"})
        ids = ds.observation_ids()
    # the configured object that the frames do show is still listed, and only it
    assert ids and {i.split("/")[0] for i in ids} == {"box"}
    assert ds.seen_objects == [1, 2, 3, 4]


@pytest.mark.data
def test_tyol_config_composes_and_loads_the_shared_frame(shared_data):
    from hydra import compose, initialize_config_module

    from catpose.bench.run.build import build_from_config

    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose(
            "run",
            overrides=[
                "dataset=tyol",
                f"dataset.root={shared_data / 'bop' / 'tyol'}",
                f"dataset.templates_root={shared_data / 'templates'}",
            ],
        )
    name, ds = build_from_config(cfg.dataset, "dataset")
    assert name == "tyol" and ds.observation_ids() == ["basket/000019/000010/0"]
    # the shared frame has neither targets nor scene_gt_info; its 74 other frames have no depth image
    assert ds.filters == ["74 frames of scene_gt.json without a depth image left out (no target list)"]
    assert len(ds.category_templates("mug")) == 1 and len(ds.category_templates("bottle")) == 1


def _edit(path: Path, change) -> None:
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def test_issue60_ground_truth_and_cameras_are_checked(bop_root):
    """Issue 60 cases 6 (a zero or scaled cam_R_m2c scored as a pose), 24 (NaN in cam_t_m2c)
    and 25 (depth_scale 0, negative, NaN, null or text): one line naming the file and the key."""
    gt_path, cam_path = bop_root / "test/000001/scene_gt.json", bop_root / "test/000001/scene_camera.json"
    good_gt, good_cam = gt_path.read_text(), cam_path.read_text()
    for key, value, match in (
        ("cam_R_m2c", [0.0] * 9, r"image 0, object index 0: cam_R_m2c is not a rotation \(max \|R\^T R - I\| = 1"),
        ("cam_R_m2c", (2 * np.eye(3)).ravel().tolist(), "cam_R_m2c is not a rotation"),
        ("cam_t_m2c", [float("nan"), 0.0, 500.0], "cam_t_m2c .* is not 3 finite numbers"),
    ):
        _edit(gt_path, lambda d: d["0"][0].update({key: value}))
        with pytest.raises(DatasetError, match=match):
            BOP(str(bop_root), categories=CATS).observation("box/000001/000000/0")
        gt_path.write_text(good_gt)
    for scale in (0, -1, float("nan"), None, "abc"):
        _edit(cam_path, lambda d: d["0"].update(depth_scale=scale))
        with pytest.raises(DatasetError, match=f"depth_scale of image 0 is {scale!r}; it must be a positive number"):
            BOP(str(bop_root), categories=CATS).observation("box/000001/000000/0")
        cam_path.write_text(good_cam)


def test_issue60_depth_in_another_unit_than_the_model_is_named(bop_root):
    """Issue 60 case 8: depth_scale 10 times too large, or a model 1e6 times too large, was scored
    (151 deg) without a word."""
    import trimesh
    from PIL import Image

    depth = np.asarray(Image.open(bop_root / "test/000001/depth/000000.png")).astype(float)
    v, f = models()[1]
    rendered = render_depth(v, f, T_camera_model(1), CAMERA)
    (bop_root / "test/000001/mask_visib").mkdir()
    mask = (rendered > 0) & (np.abs(depth - rendered) < 5)
    Image.fromarray((mask * 255).astype(np.uint8)).save(bop_root / "test/000001/mask_visib/000000_000000.png")
    BOP(str(bop_root), categories=CATS).observation("box/000001/000000/0")  # right units: loads
    _edit(bop_root / "test/000001/scene_camera.json", lambda d: d["0"].update(depth_scale=10.0))
    with pytest.raises(DatasetError, match="the depth and the model are in different units; fix depth_scale"):
        BOP(str(bop_root), categories=CATS).observation("box/000001/000000/0")
    _edit(bop_root / "test/000001/scene_camera.json", lambda d: d["0"].update(depth_scale=1.0))
    mesh = trimesh.load(bop_root / "models/obj_000001.ply", process=False)
    mesh.vertices *= 1e6  # the model in another unit than the depth (the issue's other half of case 8)
    mesh.export(bop_root / "models/obj_000001.ply")
    with pytest.raises(DatasetError, match="the depth and the model are in different units"):
        BOP(str(bop_root), categories=CATS).observation("box/000001/000000/0")


def test_issue60_targets_without_ground_truth_are_said(bop_root):
    """Issue 60 case 7: a target whose scene_gt.json entry is gone was dropped in silence."""
    (bop_root / "test_targets_bop19.json").write_text(
        json.dumps([{"scene_id": 1, "im_id": 0, "obj_id": o, "inst_count": 1} for o in (1, 2)])
    )
    _edit(bop_root / "test/000001/scene_gt.json", lambda d: d.update({"0": d["0"][:1]}))
    ds = BOP(str(bop_root), categories=CATS)
    with pytest.warns(UserWarning, match=r"1 targets of test_targets_bop19.json have no ground truth .*object 2"):
        assert ds.observation_ids() == ["box/000001/000000/0"]


def test_mask_noise_corrupts_the_loaded_mask_by_seed(bop_root):
    """``dataset.mask_noise`` gives the BOP loader a segmenter's masks (datasets/mask_noise.py):
    0 leaves the mask, 1 moves it, the same under one seed, out of range is a one-line error."""
    sid = "box/000001/000000/0"
    clean = BOP(str(bop_root), categories=CATS, max_points=0).instance_frame(sid).frame.mask
    noisy = [
        BOP(str(bop_root), categories=CATS, max_points=0, mask_noise=1.0).instance_frame(sid).frame.mask for _ in (0, 1)
    ]
    np.testing.assert_array_equal(noisy[0], noisy[1])
    assert noisy[0].shape == clean.shape and (noisy[0] != clean).any()
    with pytest.raises(ConfigError, match="dataset.mask_noise"):
        BOP(str(bop_root), mask_noise=1.5)
