"""The procedural chairs (``dataset=procedural dataset.category=chair``): a root the resampled loader
reads, fixed by its seed, and built in the category frame the shared chairs use (y up, the back
towards +z), so their identity alignment rows are right."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from catpose.datasets.procedural import ProceduralSpec, build_root


def build(root: Path, count: int, seed: int) -> Path:
    return build_root(root, ProceduralSpec(category="chair", count=count, shape_seed=seed))


def test_a_root_the_loader_reads(tmp_path):
    from catpose.datasets.modelnet40_resampled import RESAMPLED_FRAME, ModelNet40Resampled, read_resampled_txt

    build(tmp_path / "root", 3, 0)
    root = tmp_path / "root"
    ids = (root / "modelnet40_train.txt").read_text().split()
    assert ids == ["chair_8000", "chair_8001", "chair_8002"]
    assert (root / "modelnet40_test.txt").read_text() == ""
    pts, nrm = read_resampled_txt(root / "chair" / "chair_8000.txt")
    assert pts.shape == (10000, 3)
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-5)
    rows = (root / "alignment_chair.csv").read_text().splitlines()
    assert rows[1] == "chair,chair_8000,1,0,0,0,1,0,0,0,1,0,false,,,true,procedural: built in the category frame"
    ds = ModelNet40Resampled(
        str(root),
        categories=["chair"],
        split="train",
        views_per_instance=1,
        frame=replace(RESAMPLED_FRAME, alignment_table=str(root / "alignment_chair.csv")),
    )
    assert len(ds.observation_ids()) == 3


def test_the_seed_fixes_every_chair(tmp_path):
    build(tmp_path / "a", 2, 5)
    build(tmp_path / "b", 2, 5)
    build(tmp_path / "c", 2, 6)
    a, b, c = ((tmp_path / d / "chair" / "chair_8001.txt").read_bytes() for d in "abc")
    assert a == b
    assert a != c


def test_chairs_stand_in_the_shared_chairs_frame(tmp_path):
    """Every chair is taller than wide, and its highest tenth (the back's top) stands behind the
    seat's centre (+z) and on its middle (x), as in the shared resampled chairs."""
    build(tmp_path / "root", 12, 1)
    for path in sorted((tmp_path / "root" / "chair").glob("*.txt")):
        P = np.loadtxt(path, delimiter=",")[:, :3]
        P = P - (P.max(0) + P.min(0)) / 2
        extent = P.max(0) - P.min(0)
        assert extent[1] > extent[0] and extent[1] > extent[2], path.name
        top = P[P[:, 1] >= np.quantile(P[:, 1], 0.9)].mean(0)
        assert top[2] > 0.2 * extent[2] and abs(top[0]) < 0.1 * extent[0], (path.name, top)
