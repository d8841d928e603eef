"""``Registration.ambiguous`` (issue 61): a runner-up that lost by less than the margin chosen in
``results/runner_up/dev.md``; ``catpose.register`` says so in one warning."""

from __future__ import annotations

import importlib
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from catpose.api.result import AMBIGUOUS_MARGIN, Registration

register_module = importlib.import_module("catpose.api.register")  # the module; catpose.api.register is the function

REPO = Path(__file__).resolve().parents[1]


def _result(margin: float | None) -> Registration:
    second = None if margin is None else np.diag([1.0, -1.0, -1.0, 1.0])
    return Registration(
        T_template_camera=np.eye(4),
        score=0.1,
        candidates=np.eye(4)[None],
        candidate_scores=np.array([0.1]),
        method="ours",
        scale=1.0,
        up_camera=None,
        runner_up=second,
        runner_up_margin=float("nan") if margin is None else margin,
    )


def test_the_threshold_is_the_margin_the_runner_up_study_chose():
    chosen = re.search(r"Chosen: \*\*([0-9.]+)\*\*", (REPO / "results/runner_up/dev.md").read_text())
    assert chosen and float(chosen.group(1)) == AMBIGUOUS_MARGIN
    # one named constant: no other product or example file spells the number
    spelled = [
        p.relative_to(REPO).as_posix()
        for folder in ("src", "methods", "bench", "datasets", "examples")
        for p in (REPO / folder).rglob("*.py")
        if chosen.group(1) in p.read_text()
    ]
    assert spelled == ["src/catpose/api/result.py"], spelled


def test_ambiguous_below_the_margin_only_and_only_with_a_runner_up():
    assert _result(0.0014).ambiguous and _result(AMBIGUOUS_MARGIN * 0.999).ambiguous
    assert not _result(AMBIGUOUS_MARGIN).ambiguous and not _result(1.2).ambiguous
    assert not _result(None).ambiguous and _result(None).doubt() is None
    line = _result(0.0014).doubt()
    assert "\n" not in line and "0.0014" in line and str(AMBIGUOUS_MARGIN) in line and "runner_up" in line
    assert "max_poses" in line  # the cue a user may know: docs/real-scenes.md


@pytest.mark.parametrize("margin, warns", [(0.0014, True), (1.2, False), (None, False)])
def test_register_warns_in_one_line_when_the_answer_is_ambiguous(monkeypatch, margin, warns):
    class FakeRegistrar:  # the registration itself is tested elsewhere; here its result's reading
        def __init__(self, *args, **kwargs):
            pass

        def __call__(self, *args, **kwargs):
            return _result(margin)

    monkeypatch.setattr(register_module, "Registrar", FakeRegistrar)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = register_module.register(np.zeros((10, 3)), np.zeros((10, 3)))
    messages = [str(w.message) for w in caught if "ambiguous" in str(w.message)]
    assert result.ambiguous is warns and len(messages) == int(warns), messages
    assert all("\n" not in m and caught[0].filename == __file__ for m in messages)
