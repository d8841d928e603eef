"""results/category/dev/procedural_airplanes.py: the procedural development airplanes are a root
the resampled loader reads, fixed by their seed, built in the frame the verified alignment table
puts the shared airplanes in (y up, nose towards +z, tail towards -z), with their kind in each
row's note (read back by one_template_turns.py)."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
DEV = REPO / "results" / "category" / "dev"


@pytest.fixture(scope="module")
def generator():
    return runpy.run_path(str(DEV / "procedural_airplanes.py"))


def build(generator, root: Path, n: int, seed: int, *extra: str) -> None:
    assert generator["main"]([str(root), "--n", str(n), "--seed", str(seed), *extra]) == 0


def test_a_root_the_loader_reads_with_linked_templates(generator, tmp_path):
    from catpose.datasets.modelnet40_resampled import ModelNet40Resampled, read_resampled_txt

    shared = tmp_path / "shared"
    shared.mkdir()
    build(generator, tmp_path / "planes", 1, 0)  # a stand-in for the shared airplane_0536
    (tmp_path / "planes" / "airplane" / "airplane_8000.txt").rename(shared / "airplane_0536.txt")
    root = tmp_path / "root"
    build(
        generator,
        root,
        2,
        0,
        "--templates",
        str(shared),
        "airplane_0536",
        str(REPO / "results" / "alignment" / "modelnet40_resampled_airplane.csv"),
    )
    assert (root / "modelnet40_train.txt").read_text().split() == ["airplane_0536", "airplane_8000", "airplane_8001"]
    pts, nrm = read_resampled_txt(root / "airplane" / "airplane_8001.txt")
    assert pts.shape == (10000, 3) and np.linalg.norm(pts, axis=1).max() <= 1.0 + 1e-5
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-5)
    rows = (root / "alignment_airplane.csv").read_text().splitlines()
    assert rows[-1].startswith("airplane,airplane_0536,-1,0,0,0,-1,0,0,0,1,180,")  # the verified row, as it is
    ds = ModelNet40Resampled(
        str(root),
        categories=["airplane"],
        split="train",
        views_per_instance=1,
        alignment_table=str(root / "alignment_airplane.csv"),
    )
    assert len(ds.observation_ids()) == 3


def test_the_seed_fixes_every_airplane(generator, tmp_path):
    build(generator, tmp_path / "a", 2, 5)
    build(generator, tmp_path / "b", 2, 5)
    build(generator, tmp_path / "c", 2, 6)
    a, b, c = ((tmp_path / d / "airplane" / "airplane_8001.txt").read_bytes() for d in "abc")
    assert a == b
    assert a != c


def test_airplanes_stand_in_the_shared_airplanes_frame_and_carry_their_kind(generator, tmp_path):
    """Every airplane is flat (y the shortest extent) and mirror-symmetric across x = 0; but for
    a biplane, whose upper wing is its highest part, the highest 5 % (the fin) stands behind the
    middle (-z)."""
    build(generator, tmp_path, 15, 2)
    kinds = runpy.run_path(str(DEV / "one_template_turns.py"))["kinds_of"](tmp_path / "alignment_airplane.csv")
    assert len(kinds) == 15 and set(kinds.values()) <= {"airliner", "prop", "fighter", "biplane", "glider"}
    assert len(set(kinds.values())) >= 3
    for name, kind in kinds.items():
        P = np.loadtxt(tmp_path / "airplane" / f"{name}.txt", delimiter=",")[:, :3]
        extent = P.max(0) - P.min(0)
        assert extent[1] < extent[0] and extent[1] < extent[2], name
        assert abs(P[:, 0].mean()) < 0.02, name
        if kind != "biplane":
            top = P[P[:, 1] >= np.quantile(P[:, 1], 0.95)].mean(0)
            assert top[2] < -0.1, (name, kind, top)


def test_one_template_turns_reads_the_stored_turns_of_each_view():
    """one_template_turns.chosen_errors: with no turns each view keeps its own estimate; with the
    half turn, a view whose turned candidate costs less keeps that candidate's error."""
    import pandas as pd

    turns_mod = runpy.run_path(str(DEV / "one_template_turns.py"))
    half = np.diag([-1.0, -1.0, 1.0, 1.0])  # a half turn about z
    rows = []
    for view, own_cost, turn_cost in (
        ("airplane/airplane_8000/v00", 0.30, 0.10),
        ("airplane/airplane_8001/v00", 0.10, 0.30),
    ):
        rows.append(
            {
                "group_id": view,
                "sample_id": f"{view}|0",
                "status": "ok",
                "score": own_cost,
                "err_deg": 180.0,
                "rot_err_deg": 180.0,
                "runtime_s": 1.0,
                "T_gt": half.tolist(),
                "T_est": np.eye(4).tolist(),
                "info": {
                    "cross_costs": [own_cost],
                    "top_offset": 0.0,
                    "turns": [
                        {
                            "turn_deg": 180.0,
                            "T_template_camera": half.tolist(),
                            "cross_costs": [turn_cost],
                            "top_offset": 0.0,
                        }
                    ],
                },
            }
        )
    samples = pd.DataFrame(rows)
    np.testing.assert_allclose(turns_mod["chosen_errors"](samples, (), 0.05), [180.0, 180.0])
    np.testing.assert_allclose(turns_mod["chosen_errors"](samples, (180.0,), 0.05), [0.0, 180.0], atol=1e-6)
