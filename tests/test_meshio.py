"""Mesh reading (OFF with the ModelNet40 quirk, OBJ, PLY) and templates from mesh files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from catpose.datasets.meshio import (
    R_template_file,
    read_mesh,
    sample_outer_surface,
)
from catpose.datasets.templates import TemplateOptions, TemplateSet, load_template
from catpose.errors import DatasetError

# an asymmetric box: 4 x 2 x 1 (x, y, z), corner at the origin
BOX_V = np.array([[0, 0, 0], [4, 0, 0], [4, 2, 0], [0, 2, 0], [0, 0, 1], [4, 0, 1], [4, 2, 1], [0, 2, 1]], float)
BOX_QUADS = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]


def write_off(
    path: Path, vertices: np.ndarray, faces: list[list[int]], quirk: bool = False, crlf: bool = False
) -> Path:
    """OFF writer; ``quirk`` puts 'OFF' and the counts on one line as some ModelNet40 files do."""
    head = [f"OFF{len(vertices)} {len(faces)} 0"] if quirk else ["OFF", f"{len(vertices)} {len(faces)} 0"]
    lines = head + [" ".join(f"{x:g}" for x in v) for v in vertices] + [" ".join(map(str, [len(f), *f])) for f in faces]
    path.write_text(("\r\n" if crlf else "\n").join(lines) + "\n")
    return path


def test_off_quirk_and_crlf_parse_like_a_plain_off(tmp_path):
    plain = read_mesh(write_off(tmp_path / "a.off", BOX_V, BOX_QUADS))
    quirky = read_mesh(write_off(tmp_path / "b.off", BOX_V, BOX_QUADS, quirk=True, crlf=True))
    np.testing.assert_array_equal(plain[0], BOX_V)
    assert plain[1].shape == (12, 3)  # 6 quads triangulated
    np.testing.assert_array_equal(plain[0], quirky[0])
    np.testing.assert_array_equal(plain[1], quirky[1])


@pytest.mark.parametrize(
    "text",
    [
        "PLY\n3 1 0\n",
        "OFF\nthree 1 0\n0 0 0\n",
        "OFF\n8 6 0\n0 0 0\n",  # truncated
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",  # an index outside
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 x 2\n",
        "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
        "OFF\n# comment\n\n3 1 0\n0 0 0\n1 0 0\n0 y 0\n3 0 1 2\n",
        "OFF3 1 0\r\n0 0 0\r\n1 0\r\n0 1 0\r\n3 0 1 2\r\n",
    ],
)
def test_malformed_off_raises_one_line_naming_the_file(tmp_path, text):
    path = tmp_path / "bad.off"
    path.write_text(text)
    with pytest.raises(DatasetError) as info:
        read_mesh(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_missing_and_unsupported_files(tmp_path):
    with pytest.raises(DatasetError, match="does not exist"):
        read_mesh(tmp_path / "nope.obj")
    (tmp_path / "x.stl").write_text("solid")
    with pytest.raises(DatasetError, match="unsupported mesh format"):
        read_mesh(tmp_path / "x.stl")


def test_obj_and_ply_read_the_same_box(tmp_path):
    import trimesh

    mesh = trimesh.Trimesh(BOX_V, read_mesh(write_off(tmp_path / "a.off", BOX_V, BOX_QUADS))[1], process=False)
    mesh.export(tmp_path / "box.obj")
    mesh.export(tmp_path / "box.ply")
    for name in ("box.obj", "box.ply"):
        v, f = read_mesh(tmp_path / name)
        assert f.shape == (12, 3)
        np.testing.assert_allclose(np.sort(v, axis=0)[[0, -1]], np.sort(BOX_V, axis=0)[[0, -1]], atol=1e-6)


def test_R_template_file_maps_up_to_z_and_forward_to_x():
    for up, fw in [("+y", "+z"), ("+z", "+x"), ("-x", "+y"), ("+y", "-x")]:
        R = R_template_file(up, fw)
        assert np.allclose(R @ R.T, np.eye(3)) and np.isclose(np.linalg.det(R), 1.0)
        axes = {"x": 0, "y": 1, "z": 2}
        u = np.zeros(3)
        u[axes[up[1]]] = 1 if up[0] == "+" else -1
        f = np.zeros(3)
        f[axes[fw[1]]] = 1 if fw[0] == "+" else -1
        np.testing.assert_allclose(R @ u, [0, 0, 1])
        np.testing.assert_allclose(R @ f, [1, 0, 0])
    with pytest.raises(DatasetError, match="different axes"):
        R_template_file("+y", "-y")
    with pytest.raises(DatasetError, match="not one of"):
        R_template_file("up", "+x")


def test_template_from_y_up_obj_is_z_up_unit_sphere_with_outward_normals(tmp_path):
    import trimesh

    # the same box stored y-up: its height (1) along y, its length (4) along -z
    v_file = BOX_V[:, [1, 2, 0]] * np.array([1, 1, -1]) * 10.0  # (y, z, -x) -> file (x, y, z), in cm
    tri = read_mesh(write_off(tmp_path / "a.off", BOX_V, BOX_QUADS))[1]
    trimesh.Trimesh(v_file, tri[:, ::-1], process=False).export(tmp_path / "box_y_up.obj")
    spec = {"path": "box_y_up.obj", "up": "+y", "forward": "-z"}
    t = load_template("box", spec, n_points=500, seed=1, base_dir=tmp_path)
    assert t.template_id == "box/box_y_up" and t.points.shape == (500, 3) and t.has_mesh
    ext = np.ptp(t.vertices, axis=0)
    np.testing.assert_allclose(ext / ext.max(), [1.0, 0.5, 0.25], atol=1e-9)  # x long, z short: z up, x forward
    np.testing.assert_allclose(np.linalg.norm(t.vertices, axis=1).max(), 1.0)
    np.testing.assert_allclose(0.5 * (t.vertices.min(0) + t.vertices.max(0)), 0.0, atol=1e-12)
    assert (np.einsum("ij,ij->i", t.normals, t.points) > 0).all()  # convex and centred: outward


def test_outer_surface_sampling_ignores_a_hidden_inner_box(tmp_path):
    tri = read_mesh(write_off(tmp_path / "a.off", BOX_V, BOX_QUADS))[1]
    outer = (BOX_V - BOX_V.mean(0)) / 2.5
    inner = outer * 0.3
    v = np.concatenate([outer, inner])
    f = np.concatenate([tri, tri + 8])
    pts, nrm = sample_outer_surface(v, f, 1000, seed=0)
    half = np.abs(outer).max(0)
    on_outer = (np.abs(np.abs(pts) - half) < 1e-6).any(axis=1)
    assert on_outer.all()
    assert np.allclose(np.linalg.norm(nrm, axis=1), 1.0)


def test_template_set_resolves_paths_instances_and_bad_entries(tmp_path):
    write_off(tmp_path / "box.off", BOX_V, BOX_QUADS)
    calls = []

    def loader(category, instance_id):
        calls.append((category, instance_id))
        return load_template(category, {"path": str(tmp_path / "box.off"), "template_id": instance_id}, n_points=100)

    entries = {"box": ["box.off", {"path": "box.off", "up": "+x", "forward": "+y"}, "inst_1"]}
    ts = TemplateSet(TemplateOptions(entries, template_points=100), tmp_path, instance_loader=loader)
    got = ts.get("box")
    assert [t.template_id for t in got] == ["box/box", "box/box", "inst_1"] and calls == [("box", "inst_1")]
    assert ts.get("box")[0] is got[0]  # loaded once
    assert ts.get("other") == []
    with pytest.raises(DatasetError, match="unknown keys"):
        TemplateSet(TemplateOptions({"box": [{"path": "box.off", "upp": "+z"}]}), tmp_path).get("box")
    with pytest.raises(DatasetError, match="no instances"):
        TemplateSet(TemplateOptions({"box": ["inst_2"]}), tmp_path).get("box")


@pytest.mark.data
def test_real_meshes_load(shared_data):
    for path in sorted((shared_data / "ModelNet40").glob("*/train/*.off"))[:3] + [
        shared_data / "templates/robosuite/bottle.obj",
        shared_data / "templates/pyvista/airplane.ply",
    ]:
        v, f = read_mesh(path)
        assert len(v) > 3 and len(f) > 1
    chair = load_template(
        "chair",
        {"path": "shapenet/chair/models/model_normalized.obj", "up": "+y", "forward": "+z"},
        n_points=256,
        base_dir=shared_data,
    )
    ext = np.ptp(chair.vertices, axis=0)
    assert ext[2] > ext[0]  # the ShapeNet chair is taller than wide once y-up becomes z-up
