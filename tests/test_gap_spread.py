"""experiments/category_choice/gap_spread.py: views of one chair are drawn together, without replacement,
and a view's gap is its chosen error less the best of its K registrations."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_fixture  # noqa: E402

pytestmark = pytest.mark.experiment

spread = study_fixture("experiments/category_choice/gap_spread.py")


def test_a_draw_takes_whole_chairs_without_replacement(spread):
    # chair a's views all gap 0, chair b's 10, chair c's 1, 2, 3, 4
    inst = np.array(["a"] * 4 + ["b"] * 4 + ["c"] * 4)
    gaps = np.array([0.0] * 4 + [10.0] * 4 + [1.0, 2.0, 3.0, 4.0])
    d = spread["drawn_gaps"](inst, gaps, 2, 4, 3000, np.random.default_rng(0))
    # two different chairs, all 4 views of each: the only means are (0+10)/2, (0+2.5)/2, (10+2.5)/2
    assert set(np.round(d, 9)) == {5.0, 1.25, 6.25}
    one = spread["drawn_gaps"](inst, gaps, 1, 2, 3000, np.random.default_rng(1))
    # one chair, two of its views without replacement: never a view twice (chair c: 1.5 ... 3.5)
    assert set(np.round(one, 9)) == {0.0, 10.0, 1.5, 2.0, 2.5, 3.0, 3.5}


def test_too_few_chairs_is_a_clear_stop(spread):
    with pytest.raises(SystemExit, match="need 3"):
        spread["drawn_gaps"](np.array(["a", "a", "b", "b"]), np.zeros(4), 3, 2, 10, np.random.default_rng(0))


def _row(view, k, err, score, inst):
    return {
        "group_id": view,
        "sample_id": f"{view}|{k}",
        "instance_id": inst,
        "status": "ok",
        "err_deg": err,
        "score": score,
        "info": {},
        "T_est": None,
        "runtime_s": 0.0,
    }


def test_a_view_gap_is_chosen_less_oracle(spread):
    # score rule: the lowest score is chosen; view v0 keeps its 30-degree registration (oracle 5),
    # view v1 its best one
    rows = [
        _row("v0", 0, 30.0, 0.1, "a"),
        _row("v0", 1, 5.0, 0.2, "a"),
        _row("v1", 0, 2.0, 0.1, "b"),
        _row("v1", 1, 9.0, 0.3, "b"),
    ]
    inst, gaps = spread["view_gaps"](pd.DataFrame(rows), "score", ())
    assert list(inst) == ["a", "b"]
    np.testing.assert_allclose(gaps, [25.0, 0.0])
