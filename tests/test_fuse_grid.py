"""experiments/category_choice/fuse_grid.py: each setting's rows are the ``cross_top_turns`` choice, or
that choice averaged with the agreeing templates within the setting's angle."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_fixture  # noqa: E402

pytestmark = pytest.mark.experiment

grid = study_fixture("experiments/category_choice/fuse_grid.py")


def _pose(deg: float) -> list:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", deg, degrees=True).as_matrix()
    return T.tolist()


def _view(view: str, degs, costs):
    return [
        {
            "group_id": view,
            "sample_id": f"{view}|{k}",
            "status": "ok",
            "score": 0.1,
            "err_deg": abs(d),
            "T_est": _pose(d),
            "T_gt": np.eye(4).tolist(),
            "runtime_s": 0.0,
            "info": {
                "cross_costs": c,
                "top_offset": 0.0,
                "turns": [
                    {"turn_deg": 90.0, "T_template_camera": _pose(d + 90), "cross_costs": [1.0, 1.0], "top_offset": 0.0}
                ],
            },
        }
        for k, (d, c) in enumerate(zip(degs, costs))
    ]


def test_each_setting_fuses_within_its_angle(grid):
    # v0: template 0 chosen at 8 degrees, template 1 at -6 agrees within 15 but not within 10;
    # v1: the two are 100 degrees apart, never averaged
    rows = pd.DataFrame(
        _view("v0", [8.0, -6.0], [[0.1, 0.1], [0.2, 0.2]]) + _view("v1", [3.0, 103.0], [[0.1, 0.1], [0.2, 0.2]])
    )
    plain, narrow, wide = grid["chosen"](rows, None), grid["chosen"](rows, 10.0), grid["chosen"](rows, 15.0)
    assert list(plain["err_deg"]) == [8.0, 3.0] and list(narrow["err_deg"]) == [8.0, 3.0]
    assert wide["err_deg"].tolist() == pytest.approx([1.0, 3.0])
    assert [i["fused_templates"] for i in wide["info"]] == [2, 1]
    assert all("fused_templates" not in i for i in plain["info"])


def test_each_weight_weighs_the_top_offset(grid):
    # template 1 (90 degrees off) costs less but puts its top 0.5 further out: a weight of 0.1
    # keeps template 0, one of 0.01 does not
    rows = pd.DataFrame(_view("v0", [2.0, 90.0], [[0.30, 0.30], [0.30, 0.27]]))
    rows["info"] = [{**rows["info"][0], "top_offset": 0.1}, {**rows["info"][1], "top_offset": 0.6}]
    assert grid["chosen"](rows, None, 0.01)["err_deg"].tolist() == [90.0]
    assert grid["chosen"](rows, None, 0.1)["err_deg"].tolist() == [2.0]
