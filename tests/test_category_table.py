"""``python experiments/_lib/category_table.py``: the K-template tables with the chosen, oracle and
random-template errors side by side (issue 25), and its one-line errors."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_module  # noqa: E402
from _trust import write_run  # noqa: E402
from test_bad_inputs_round2 import TEMPLATES_CFG, templates_rows  # noqa: E402
from test_template_choice import view_rows  # noqa: E402

from catpose.methods.choice_rules import RULES  # noqa: E402

pytestmark = pytest.mark.experiment

ct = study_module("experiments/_lib/category_table.py")


def test_category_table_reports_chosen_oracle_and_random_side_by_side(ct):
    rows = pd.concat(
        [
            view_rows("chair/a/v00", [0, 170, 5], [0.2, 0.1, 0.15], [3.0, 170.0, 4.0]),
            view_rows("chair/b/v00", [0, 90, 3], [0.1, 0.2, 0.3], [2.0, 90.0, 40.0]),
        ],
        ignore_index=True,
    )
    out = ct.run_rows(SimpleNamespace(samples=rows), "chair", ["score", "agreement"])
    score, agree = out
    assert score["K"] == 3 and score["views"] == 2
    assert score["chosen_mean"] == pytest.approx((170.0 + 2.0) / 2)
    assert agree["chosen_mean"] == pytest.approx((4.0 + 2.0) / 2)
    assert score["oracle_mean"] == pytest.approx(2.5) and score["oracle_acc10"] == 1.0
    every = [3.0, 170.0, 4.0, 2.0, 90.0, 40.0]  # a random template: all registrations pooled
    assert score["random_mean"] == pytest.approx(np.mean(every))
    assert score["random_acc30"] == pytest.approx(3 / 6)
    assert ct.error_stats(np.array([]))["mean"] != ct.error_stats(np.array([]))["mean"]  # NaN
    md = ct.to_markdown([{"method": "Ours", **r} for r in out], "t")
    assert "| 3 | Ours | agreement | 2 | 3.00 |" in md and md.count("\n") == 6
    assert set(RULES) == {"score", "density", "agreement", "cross", "cross_top", "cross_top_turns", "fused"}
    one = ct.run_rows(SimpleNamespace(samples=view_rows("chair/c/v00", [0], [0.2], [7.0])), "chair", ["cross", "score"])
    assert [(r["K"], r["choice"], r["chosen_mean"]) for r in one] == [(1, "-", 7.0)]  # one template: nothing chosen


def test_category_table_one_template_row_takes_the_runs_turn_rule_where_turns_were_stored(ct):
    rows = view_rows("chair/c/v00", [90], [0.2], [90.0])
    rows["sample_id"] = ["chair/c/v00|0"]
    rows["T_gt"] = [np.eye(4).tolist()]
    rows["info"] = [
        {
            "cross_costs": [0.3],
            "top_offset": 0.0,
            "turns": [
                {"turn_deg": 270.0, "T_template_camera": np.eye(4).tolist(), "cross_costs": [0.1], "top_offset": 0.0}
            ],
        }
    ]
    [row] = ct.run_rows(
        SimpleNamespace(samples=rows, config={"protocol": {"choice": "cross_top_turns"}}), "chair", ["cross", "score"]
    )
    assert row["choice"] == "cross_top_turns" and row["chosen_mean"] == pytest.approx(0.0, abs=1e-6)
    assert row["oracle_mean"] == 90.0  # the registration's own estimate
    # a run under another rule keeps the own estimate, as does a turn-rule run that stored no turns
    plain = ct.run_rows(SimpleNamespace(samples=rows, config={"protocol": {"choice": "score"}}), "chair", ["cross"])
    assert [(r["choice"], r["chosen_mean"]) for r in plain] == [("-", 90.0)]
    rows["info"] = [{}]
    bare = ct.run_rows(
        SimpleNamespace(samples=rows, config={"protocol": {"choice": "cross_top_turns"}}), "chair", ["cross"]
    )
    assert [(r["choice"], r["chosen_mean"]) for r in bare] == [("-", 90.0)]


def test_a_view_on_fewer_templates_than_its_K_is_said(ct, tmp_path, capsys):
    cfg = dict(TEMPLATES_CFG, choice={"name": "score", "rule": "score"})
    run = write_run(tmp_path / "run", templates_rows(n_views=1, k=3, present=2), cfg)  # limit=2
    assert ct.main([str(run)]) == 0
    out, err = capsys.readouterr()
    row = next(ln for ln in out.splitlines() if ln.startswith("| 3 |"))  # K = 3, not 2
    assert "Note: Ours (K = 3): 1 of 1 views were registered to fewer than 3 templates" in out
    assert "category_table: warning: Ours (K = 3): 1 of 1 views" in err and row
    (tmp_path / "adir").mkdir()
    assert ct.main([str(run), "--out", str(tmp_path / "adir"), "--force"]) == 2
    assert "is a folder; pass the file to write" in capsys.readouterr().err
