"""experiments/selection_breadth/selection_grid.py: a sweep's runs of the same views, each setting's kept
estimates and oracle, split into the instances that chose the setting and those that confirm it."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_fixture  # noqa: E402

pytestmark = pytest.mark.experiment

TEMPLATES = {"_target_": "catpose.bench.protocols.Templates", "name": "templates"}
grid = study_fixture("experiments/selection_breadth/selection_grid.py")


def _rows(instance: str, errs, scores, seconds=0.02):
    view = f"chair/{instance}/v00"
    return [
        {
            "group_id": view,
            "sample_id": f"{view}|{k}",
            "instance_id": instance,
            "status": "ok",
            "score": s,
            "err_deg": e,
            "T_est": np.eye(4).tolist(),
            "T_gt": np.eye(4).tolist(),
            "runtime_s": seconds,
            "info": {},
        }
        for k, (e, s) in enumerate(zip(errs, scores))
    ]


def test_setting_reads_a_dotted_key(grid):
    config = {"method": {"selection": {"top_k": 18}}}
    assert grid["setting"](config, "method.selection.top_k") == 18
    assert grid["setting"](config, "method.selection.rule") is None and grid["setting"]({}, "method.x") is None


def test_view_table_keeps_the_runs_own_choice_with_the_oracle(grid):
    # chair_a: the lower score (template 1) is 40 degrees off, the oracle 5; chair_b: the score keeps the best
    rows = _rows("chair_a", [5.0, 40.0], [0.3, 0.2]) + _rows("chair_b", [2.0, 90.0], [0.1, 0.4], seconds=0.04)
    run = SimpleNamespace(
        config={"protocol": TEMPLATES, "choice": {"name": "score", "rule": "score"}}, samples=pd.DataFrame(rows)
    )
    ids, kept, oracle, seconds = grid["view_table"](run)
    assert list(ids) == ["chair_a", "chair_b"]
    assert kept.tolist() == [40.0, 2.0] and oracle.tolist() == [5.0, 2.0]
    assert sorted(seconds.tolist()) == [0.02, 0.02, 0.04, 0.04]  # every registration, not every view
    assert grid["part_stats"](kept) == "21.00 | 0.500" and grid["part_stats"](kept[:0]) == "- | -"
