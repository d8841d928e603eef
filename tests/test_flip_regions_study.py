"""experiments/flip_regions/run.py: the five regions' per-pixel costs add up to ours' depth-check
score on a lattice of stride 1 (the check's compiled kernel is the independent reference)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import REPO, study_fixture  # noqa: E402

pytestmark = pytest.mark.experiment

study = study_fixture("experiments/flip_regions/run.py")
SHARED = Path(os.environ.get("CATPOSE_SHARED_DATA", REPO.parent / "shared" / "data"))


@pytest.mark.skipif(not (SHARED / "bop" / "ycbv").is_dir(), reason="needs ../shared/data/bop/ycbv")
def test_the_regions_add_up_to_the_checks_score(study):
    sys.path.insert(0, str(REPO / "experiments" / "_lib"))
    from sample_rows import build

    from catpose.methods.ours.check import DepthVerifier
    from catpose.methods.ours.settings import SelectionSettings

    sel = SelectionSettings()
    _, _, dataset, protocol = build(0, ["dataset=ycbv", f"dataset.root={SHARED}/bop/ycbv", "dataset.scenes=[1]"])
    turn = np.diag([1.0, -1.0, -1.0, 1.0])  # a half turn about the template's x axis
    moved = np.eye(4)
    moved[0, 3] = 0.5  # half the template's radius aside
    for sid in protocol.sample_ids(dataset)[:2]:
        s = protocol.load(dataset, sid)
        p = s.problem
        n = int(p.depth_image.mask.sum())
        v = DepthVerifier(p.template, p.depth_image, sel.depth_tau, 10 * n, 10**9, sel.depth_free_weight)
        assert v.lattice.stride == 1
        T_gt = np.asarray(s.gt.T_template_camera, float)
        T = np.stack([T_gt, turn @ T_gt, moved @ T_gt])
        costs = study["region_costs"](v, T)
        assert costs.shape == (3, len(study["REGIONS"]))
        assert costs.sum(axis=1) == pytest.approx(v.scores(T), abs=1e-12)
        assert costs[2].sum() > costs[0].sum() + 0.1  # a pose half a radius aside explains far less
