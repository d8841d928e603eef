"""experiments/category_choice/one_template_turns.py: the one-template turn check read from the
runs' stored turns, per view."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import run_study  # noqa: E402

pytestmark = pytest.mark.experiment


def test_one_template_turns_reads_the_stored_turns_of_each_view():
    """chosen_errors (from top_weight_grid.py, which one_template_turns.py reads): with no turns each
    view keeps its own estimate; with the half turn, a view whose turned candidate costs less keeps
    that candidate's error."""
    import pandas as pd

    turns_mod = run_study("experiments/category_choice/one_template_turns.py")
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
