"""Alignment tables (``catpose.datasets.alignment``): read, refused in one line, applied by the
loader; the committed verified tables and the experiment configs that read them (their estimation:
``tests/test_align.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from catpose.datasets.alignment import read_alignment_table, yaw_deg_of
from catpose.datasets.modelnet40 import ModelNet40, ShapeFrame
from catpose.errors import DatasetError
from catpose.geometry import axis_angle_to_R

YAWS = [axis_angle_to_R(np.array([0, 0, 1.0]), np.pi / 2 * k) for k in range(4)]

# an "L": a long bar along +x and a short bar along +y, both 0.2 thick: no rotational symmetry
L_PARTS = [((0, 0, 0), (3, 0.5, 0.5)), ((0, 0.5, 0), (0.5, 1.5, 0.5))]


def l_shape_mesh() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    boxes = []
    for lo, size in L_PARTS:
        b = trimesh.creation.box(extents=size)
        b.apply_translation(np.asarray(lo) + np.asarray(size) / 2)
        boxes.append(b)
    m = trimesh.util.concatenate(boxes)
    return np.asarray(m.vertices), np.asarray(m.faces)


def write_off(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        "\n".join(
            [f"OFF{len(v)} {len(f)} 0"] + [" ".join(map(str, x)) for x in v] + [f"3 {a} {b} {c}" for a, b, c in f]
        )
        + "\n"
    )


def test_table_round_trip_with_matrices_and_yaw(tmp_path):
    R = YAWS[1]
    header = "category,instance_id," + ",".join(f"r{i}{j}" for i in range(3) for j in range(3)) + ",yaw_deg,flip\n"
    matrix = ",".join(f"{x:.9g}" for x in R.reshape(-1))
    (tmp_path / "t.csv").write_text(
        header + f"airplane,airplane_0002,{matrix},90,false\n" + "airplane,airplane_0003,,,,,,,,,,180,\n"
    )
    table = read_alignment_table(tmp_path / "t.csv")
    np.testing.assert_allclose(table[("airplane", "airplane_0002")], R, atol=1e-8)
    np.testing.assert_allclose(table[("airplane", "airplane_0003")], np.diag([-1.0, -1.0, 1.0]), atol=1e-12)
    assert yaw_deg_of(R) == pytest.approx(90.0)


@pytest.mark.parametrize(
    "text, words",
    [
        ("category,instance_id,foo\n", "needs columns"),
        ("category,instance_id,yaw_deg\nairplane,a,abc\n", "line 2"),
        (
            "category,instance_id,"
            + ",".join(f"r{i}{j}" for i in range(3) for j in range(3))
            + "\nairplane,a,1,0,0,0,1,0,0,0,2\n",
            "not a rotation",
        ),
    ],
)
def test_bad_tables_raise(tmp_path, text, words):
    (tmp_path / "t.csv").write_text(text)
    with pytest.raises(DatasetError, match=words):
        read_alignment_table(tmp_path / "t.csv")
    with pytest.raises(DatasetError, match="does not exist"):
        read_alignment_table(tmp_path / "missing.csv")


def test_the_loader_applies_a_table(tmp_path):
    v, f = l_shape_mesh()
    root = tmp_path / "ModelNet40"
    write_off(root / "thing/train/thing_0001.off", v, f)
    write_off(root / "thing/train/thing_0002.off", v @ YAWS[1].T * 7.0 + 3.0, f)  # rotated, scaled, moved
    table = tmp_path / "align.csv"
    table.write_text("category,instance_id,yaw_deg\nthing,thing_0001,0\nthing,thing_0002,-90\n")
    ds = ModelNet40(str(root), categories=["thing"], split="train", frame=ShapeFrame(alignment_table=str(table)))
    a, _ = ds.canonical_mesh("thing", "thing_0001")
    b, _ = ds.canonical_mesh("thing", "thing_0002")
    np.testing.assert_allclose(a, b, atol=1e-9)
    raw = ModelNet40(str(root), categories=["thing"], split="train")
    assert not np.allclose(raw.canonical_mesh("thing", "thing_0002")[0], a, atol=1e-3)
    assert ds.observation("thing/thing_0002/v00").info["aligned"] is True


COMMITTED = Path(__file__).resolve().parents[1] / "results" / "alignment"


@pytest.mark.parametrize(
    "name, n_rows",
    [
        ("modelnet40_airplane", 6),
        ("modelnet40_chair", 3),
        ("modelnet40_resampled_airplane", 18),
        ("modelnet40_resampled_chair", 5),
    ],
)
def test_committed_tables_are_verified_yaw_tables_with_small_sheets(name, n_rows):
    import csv

    table = read_alignment_table(COMMITTED / f"{name}.csv")
    assert len(table) == n_rows
    for R in table.values():  # ModelNet40 files share their up axis: yaw steps only
        assert any(np.allclose(R, Y, atol=1e-9) for Y in YAWS)
    rows = list(csv.DictReader((COMMITTED / f"{name}.csv").open()))
    assert all(r["verified"] == "true" and r["note"] for r in rows)
    assert 0 < (COMMITTED / f"{name}.png").stat().st_size < 500_000


EXPERIMENTS = [
    "mn40r_airplane_1template",
    "mn40r_chair_ktemplates",
    "mn40r_chair_1template",
    "mn40r_airplane_ktemplates",
    "mn40r_relative",
]


@pytest.mark.parametrize("name", EXPERIMENTS)
def test_experiment_configs_compose_for_any_root_and_leave_the_templates_views_out(name):
    from hydra import compose, initialize_config_module

    from catpose.datasets.alignment import read_alignment_table

    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose("run", overrides=[f"+experiment={name}", "+row=ours", "dataset.root=/any/root"])
    assert cfg.dataset.name == "modelnet40_resampled" and cfg.dataset.root == "/any/root"
    assert cfg.protocol.exclude_templates is True and not cfg.sample_ids  # no list of one root's views
    tables = read_alignment_table([str(COMMITTED.parents[1] / p) for p in cfg.dataset.alignment_table.split(",")])
    for category in cfg.dataset.categories:
        assert {(category, t) for t in cfg.dataset.templates[category]} <= set(tables)


@pytest.mark.data
@pytest.mark.parametrize(
    "name, instances",
    [
        ("mn40r_airplane_1template", None),  # every airplane but the template
        ("mn40r_chair_ktemplates", ["chair_0454", "chair_0858"]),
        ("mn40r_chair_1template", ["chair_0454", "chair_0858"]),
    ],
)
def test_experiment_sample_ids_are_every_non_template_view(name, instances, shared_data, monkeypatch):
    from hydra import compose, initialize_config_module

    from catpose.bench.run.build import build_from_config

    monkeypatch.chdir(COMMITTED.parents[1])  # the configs' paths are relative to the repository root
    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose(
            "run",
            overrides=[
                f"+experiment={name}",
                "+row=ours",
                f"dataset.root={shared_data / 'modelnet40_normal_resampled'}",
            ],
        )
    _, dataset = build_from_config(cfg.dataset, "dataset")
    dataset.name = "modelnet40_resampled"
    _, protocol = build_from_config(cfg.protocol, "protocol")
    (category,) = cfg.dataset.categories
    K = len(cfg.dataset.templates[category])
    ids = protocol.sample_ids(dataset)
    shown = sorted({s.split("/")[1] for s in ids})
    every = sorted({o.split("/")[1] for o in dataset.observation_ids()} - set(cfg.dataset.templates[category]))
    assert shown == (instances or every)
    assert len(ids) == len(shown) * cfg.dataset.views_per_instance * K
