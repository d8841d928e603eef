"""Alignment tables, the Chamfer rotation search and the ``bench align`` command."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from catpose.bench.category import align as align_cmd
from catpose.datasets.alignment import (
    FLIP,
    estimate_table,
    read_alignment_table,
    synchronize,
    write_alignment_table,
    yaw_deg_of,
    yaw_flip_hypotheses,
    yaw_rotations,
)
from catpose.datasets.modelnet40 import ModelNet40, ShapeFrame
from catpose.errors import DatasetError
from catpose.geometry import axis_angle_to_R

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
    R = axis_angle_to_R(np.array([0, 0, 1.0]), np.pi / 2)
    write_alignment_table(
        tmp_path / "t.csv",
        [{"category": "airplane", "instance_id": "airplane_0002", "R": R, "yaw_deg": yaw_deg_of(R), "chamfer": 0.1}],
    )
    with (tmp_path / "t.csv").open("a") as fh:
        fh.write("airplane,airplane_0003,,,,,,,,,,180,\n")
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


def test_hypotheses_form_a_group():
    for flip in (False, True):
        G = yaw_flip_hypotheses(flip)
        assert len(G) == (8 if flip else 4)
        for A in G:
            for B in G:
                assert min(np.abs(G - A @ B).max(axis=(1, 2))) < 1e-9


def test_synchronize_recovers_labels_from_noisy_pairwise_costs():
    G = yaw_flip_hypotheses(True)
    rng = np.random.default_rng(0)
    truth = rng.integers(0, len(G), 7)
    truth[2] = 0
    C = rng.uniform(0.3, 0.5, size=(7, 7, len(G)))
    for i in range(7):
        for j in range(7):
            g = int(np.argmin(np.abs(G - G[truth[j]].T @ G[truth[i]]).max(axis=(1, 2))))
            C[i, j, g] = 0.2 if (i, j) != (0, 1) else 0.6  # one misleading pair
    out = synchronize(C, G, reference=2)
    np.testing.assert_array_equal(out["labels"], truth)
    assert (out["confidence"] > 0).all()


def test_estimate_table_recovers_yaws_and_a_flip_of_distinct_instances():
    from catpose.datasets.meshio import sample_outer_surface

    v, f = l_shape_mesh()
    v = v - (v.max(0) + v.min(0)) / 2
    G = yaw_flip_hypotheses(True)
    truth = [0, 1, 6, 3]  # R_reference_instance labels
    clouds = []
    for k, label in enumerate(truth):
        vk = v * (1.0 + 0.05 * k)  # distinct instances: scaled, resampled
        p, _ = sample_outer_surface(vk @ G[label], f, 600, seed=k)  # raw_k = R_ref_k^T ref
        clouds.append(p / np.linalg.norm(p, axis=1).max())
    out = estimate_table(clouds, G, reference=0)
    np.testing.assert_array_equal(out["labels"], truth)
    np.testing.assert_allclose(G[6], yaw_rotations(4)[2] @ FLIP)


def test_bench_align_writes_a_table_the_loader_applies(tmp_path, capsys):
    v, f = l_shape_mesh()
    root = tmp_path / "ModelNet40"
    write_off(root / "thing/train/thing_0001.off", v, f)
    yaw90 = axis_angle_to_R(np.array([0, 0, 1.0]), np.pi / 2)
    write_off(root / "thing/train/thing_0002.off", v @ yaw90.T * 7.0 + 3.0, f)  # rotated, scaled, moved
    out = tmp_path / "align.csv"
    verified = tmp_path / "verified.csv"  # in another frame (turned by 180 deg): agreement is up to one rotation
    write_alignment_table(
        verified,
        [
            {"category": "thing", "instance_id": "thing_0001", "R": yaw_rotations(2)[1]},
            {"category": "thing", "instance_id": "thing_0002", "R": yaw_rotations(2)[1] @ yaw90.T},
        ],
    )
    assert (
        align_cmd.main(
            [
                "dataset=modelnet40",
                f"dataset.root={root}",
                "dataset.categories=[thing]",
                "dataset.split=train",
                "--category",
                "thing",
                "--out",
                str(out),
                "--points",
                "600",
                "--compare",
                str(verified),
            ]
        )
        == 0
    )
    assert "agree 2/2" in capsys.readouterr().out
    assert (tmp_path / "align_vs_verified.csv").read_text().count(",true,") == 2
    table = read_alignment_table(out)
    np.testing.assert_allclose(table[("thing", "thing_0001")], np.eye(3), atol=1e-12)
    np.testing.assert_allclose(table[("thing", "thing_0002")], yaw90.T, atol=1e-12)
    text = out.read_text().splitlines()
    assert text[0].endswith("yaw_deg,flip,chamfer,confidence,verified,note") and ",false," in text[2]
    assert out.with_suffix(".png").stat().st_size > 1000

    ds = ModelNet40(str(root), categories=["thing"], split="train", frame=ShapeFrame(alignment_table=str(out)))
    a, _ = ds.canonical_mesh("thing", "thing_0001")
    b, _ = ds.canonical_mesh("thing", "thing_0002")
    np.testing.assert_allclose(a, b, atol=1e-9)
    raw = ModelNet40(str(root), categories=["thing"], split="train")
    assert not np.allclose(raw.canonical_mesh("thing", "thing_0002")[0], a, atol=1e-3)
    assert ds.observation("thing/thing_0002/v00").info["aligned"] is True

    sheet = tmp_path / "redrawn.png"  # --draw-only redraws the table as it is
    assert (
        align_cmd.main(
            [
                "dataset=modelnet40",
                f"dataset.root={root}",
                "dataset.categories=[thing]",
                "dataset.split=train",
                "--category",
                "thing",
                "--out",
                str(out),
                "--draw-only",
                "--sheet",
                str(sheet),
            ]
        )
        == 0
    )
    assert sheet.stat().st_size > 1000


def test_bench_align_reports_a_bad_root_in_one_line(tmp_path, capsys):
    from catpose.bench.cli import main

    assert (
        main(
            [
                "align",
                "dataset=modelnet40",
                f"dataset.root={tmp_path / 'none'}",
                "--category",
                "x",
                "--out",
                str(tmp_path / "o.csv"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.startswith("bench align: error: ") and "\n" not in err


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
        assert any(np.allclose(R, Y, atol=1e-9) for Y in yaw_rotations(4))
    rows = list(csv.DictReader((COMMITTED / f"{name}.csv").open()))
    assert all(r["verified"] == "true" and r["note"] for r in rows)
    assert 0 < (COMMITTED / f"{name}.png").stat().st_size < 500_000


@pytest.mark.data
@pytest.mark.slow
def test_shared_airplanes_fuselage_axis_matches_the_verified_table(shared_data, tmp_path):
    out = tmp_path / "airplane.csv"
    assert (
        align_cmd.main(
            [
                "dataset=modelnet40",
                f"dataset.root={shared_data / 'ModelNet40'}",
                "--category",
                "airplane",
                "--out",
                str(out),
                "--points",
                "512",
            ]
        )
        == 0
    )
    est, verified = read_alignment_table(out), read_alignment_table(COMMITTED / "modelnet40_airplane.csv")
    assert set(est) == set(verified)
    np.testing.assert_allclose(est[("airplane", "airplane_0001")], np.eye(3))
    for key, R in est.items():
        # the fuselage axis is found; nose against tail (180 deg) is what the person checks
        assert np.allclose(R, verified[key], atol=1e-9) or np.allclose(
            R, yaw_rotations(2)[1] @ verified[key], atol=1e-9
        )


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
