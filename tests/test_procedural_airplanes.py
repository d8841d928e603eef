"""The procedural airplanes (``dataset=procedural dataset.category=airplane``): a root the resampled
loader reads, fixed by their seed, built in the frame the verified alignment table puts the shared
airplanes in (y up, nose towards +z, tail towards -z), with their kind in each row's note (read back
by ``catpose.datasets.procedural.kinds``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from catpose.datasets.procedural import ProceduralSpec, build_root, kinds

REPO = Path(__file__).resolve().parents[1]


def build(root: Path, count: int, seed: int, **templates) -> Path:
    return build_root(root, ProceduralSpec(category="airplane", count=count, shape_seed=seed, **templates))


def test_a_root_the_loader_reads_with_linked_templates(tmp_path):
    from catpose.datasets.modelnet40_resampled import RESAMPLED_FRAME, ModelNet40Resampled, read_resampled_txt

    shared = tmp_path / "shared"
    build(tmp_path / "planes", 1, 0)  # a stand-in for the shared airplane_0536
    (shared / "airplane").mkdir(parents=True)
    (tmp_path / "planes" / "airplane" / "airplane_8000.txt").rename(shared / "airplane" / "airplane_0536.txt")
    root = build(
        tmp_path / "root",
        2,
        0,
        template_ids=("airplane_0536",),
        template_root=str(shared),
        template_alignment=str(REPO / "results" / "alignment" / "modelnet40_resampled_airplane.csv"),
    )
    assert (root / "modelnet40_train.txt").read_text().split() == ["airplane_0536", "airplane_8000", "airplane_8001"]
    assert (root / "airplane" / "airplane_0536.txt").is_symlink()
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
        frame=replace(RESAMPLED_FRAME, alignment_table=str(root / "alignment_airplane.csv")),
    )
    assert len(ds.observation_ids()) == 3


def test_the_seed_fixes_every_airplane(tmp_path):
    build(tmp_path / "a", 2, 5)
    build(tmp_path / "b", 2, 5)
    build(tmp_path / "c", 2, 6)
    a, b, c = ((tmp_path / d / "airplane" / "airplane_8001.txt").read_bytes() for d in "abc")
    assert a == b
    assert a != c


def test_airplanes_stand_in_the_shared_airplanes_frame_and_carry_their_kind(tmp_path):
    """Every airplane is flat (y the shortest extent) and mirror-symmetric across x = 0; but for
    a biplane, whose upper wing is its highest part, the highest 5 % (the fin) stands behind the
    middle (-z)."""
    root = build(tmp_path / "root", 15, 2)
    found = kinds(root / "alignment_airplane.csv")
    assert len(found) == 15 and set(found.values()) <= {"airliner", "prop", "fighter", "biplane", "glider"}
    assert len(set(found.values())) >= 3
    for name, kind in found.items():
        P = np.loadtxt(root / "airplane" / f"{name}.txt", delimiter=",")[:, :3]
        extent = P.max(0) - P.min(0)
        assert extent[1] < extent[0] and extent[1] < extent[2], name
        assert abs(P[:, 0].mean()) < 0.02, name
        if kind != "biplane":
            top = P[P[:, 1] >= np.quantile(P[:, 1], 0.95)].mean(0)
            assert top[2] < -0.1, (name, kind, top)
