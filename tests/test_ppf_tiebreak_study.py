"""experiments/ppf_tiebreak/tiebreak.py: the rule takes ours' runner-up only when ours' margin is below
``t`` and PPF's answer lies within ``X`` deg of the runner-up, and the tables count what it turned
right and wrong and which of a near-tie's two poses PPF sided with."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_fixture  # noqa: E402

pytestmark = pytest.mark.experiment

study = study_fixture("experiments/ppf_tiebreak/tiebreak.py")

EYE = np.eye(4)
FLIP = np.diag([1.0, -1.0, -1.0, 1.0])  # a half turn about x


def _row(sid: str, T: np.ndarray, err: float, second: tuple[np.ndarray, float, float] | None = None) -> dict:
    row = {"sample_id": sid, "status": "ok", "err_deg": err, "T_est": T.ravel().tolist(), "info": {}, "extras": {}}
    row["symmetry_axis"], row["symmetries"] = None, None
    if second is not None:
        T2, err2, margin = second
        row["extras"]["runner_up"] = {"T_template_camera": T2.tolist(), "cost": 0.1, "margin": margin}
        row["info"]["runner_up_err_deg"] = err2
    return row


def _write(folder: Path, rows: list[dict]) -> None:
    folder.mkdir(parents=True)
    (folder / "samples.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))


def test_rule_turns_a_near_tie_to_ppf_side(study, tmp_path: Path) -> None:
    # the truth is the identity; ours wrong (half turn) on a, right on b, both near-ties (margin 0.01)
    ours = [_row("a", FLIP, 180.0, (EYE, 0.0, 0.01)), _row("b", EYE, 0.0, (FLIP, 180.0, 0.01))]
    ppf = [_row("a", EYE, 0.0), _row("b", EYE, 0.0)]  # PPF right on both: near a's runner-up, not b's
    rows = study["pair_rows"]({r["sample_id"]: r for r in ours}, {r["sample_id"]: r for r in ppf})
    assert [r["ppf_to_second"] for r in rows] == pytest.approx([0.0, 180.0])
    assert study["rule_errors"](rows, 0.05, 10.0).tolist() == [0.0, 0.0]  # a turned right, b kept
    assert study["rule_errors"](rows, 0.005, 10.0).tolist() == [180.0, 0.0]  # margin not below t: ours
    for source in study["SOURCES"]:
        for seed in study["SEEDS"]:
            _write(tmp_path / source / f"ours-seed{seed}" / "run", ours)
            _write(tmp_path / source / f"ppf-seed{seed}" / "run", ppf)
    out = tmp_path / "dev.md"
    assert study["main"]([str(tmp_path), "--out", str(out)]) == 0
    text = out.read_text()
    assert "| ours | | | 0.500 [0.500-0.500] | | |" in text
    assert "| rule | 0.05 | 10 | 1.000 [1.000-1.000] | 3 | 0 |" in text
    assert "| 0.05 | 6 | 3 | 6 | 0 |" in text  # 6 ties (2 x 3 seeds), ours right on 3, PPF near the right one on 6
