"""results/category/dev/procedural_chairs.py: the procedural development chairs are a root the
resampled loader reads, fixed by their seed, and built in the category frame the shared chairs
use (y up, the back towards +z), so their identity alignment rows are right."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "results" / "category" / "dev" / "procedural_chairs.py"


@pytest.fixture(scope="module")
def generator():
    return runpy.run_path(str(SCRIPT))


def build(generator, root: Path, n: int, seed: int) -> None:
    assert generator["main"]([str(root), "--n", str(n), "--seed", str(seed)]) == 0


def test_a_root_the_loader_reads(generator, tmp_path):
    from catpose.datasets.modelnet40_resampled import ModelNet40Resampled, read_resampled_txt

    build(generator, tmp_path, 3, 0)
    ids = (tmp_path / "modelnet40_train.txt").read_text().split()
    assert ids == ["chair_8000", "chair_8001", "chair_8002"]
    pts, nrm = read_resampled_txt(tmp_path / "chair" / "chair_8000.txt")
    assert pts.shape == (10000, 3)
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-5)
    ds = ModelNet40Resampled(
        str(tmp_path),
        categories=["chair"],
        split="train",
        views_per_instance=1,
        alignment_table=str(tmp_path / "alignment_chair.csv"),
    )
    assert len(ds.observation_ids()) == 3


def test_the_seed_fixes_every_chair(generator, tmp_path):
    build(generator, tmp_path / "a", 2, 5)
    build(generator, tmp_path / "b", 2, 5)
    build(generator, tmp_path / "c", 2, 6)
    a, b, c = ((tmp_path / d / "chair" / "chair_8001.txt").read_bytes() for d in "abc")
    assert a == b
    assert a != c


def test_chairs_stand_in_the_shared_chairs_frame(generator, tmp_path):
    """Every chair is taller than wide, and its highest tenth (the back's top) stands behind the
    seat's centre (+z) and on its middle (x), as in the shared resampled chairs."""
    build(generator, tmp_path, 12, 1)
    for path in sorted((tmp_path / "chair").glob("*.txt")):
        P = np.loadtxt(path, delimiter=",")[:, :3]
        P = P - (P.max(0) + P.min(0)) / 2
        extent = P.max(0) - P.min(0)
        assert extent[1] > extent[0] and extent[1] > extent[2], path.name
        top = P[P[:, 1] >= np.quantile(P[:, 1], 0.9)].mean(0)
        assert top[2] > 0.2 * extent[2] and abs(top[0]) < 0.1 * extent[0], (path.name, top)
