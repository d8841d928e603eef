"""What :func:`catpose.register` and :class:`catpose.Registrar` return."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["AMBIGUOUS_MARGIN", "Registration"]

#: :attr:`Registration.ambiguous` below this runner-up margin (ours' depth-check cost per mask
#: pixel): the smallest margin whose answers at or above it were right (@10) on 0.99 of the 937
#: development views, chosen by experiments/runner_up and written in results/runner_up/dev.md
#: ("Chosen: **0.3251**"; tests/test_ambiguous.py reads it there). It flags 0.843 of those views;
#: on the report scenes every wrong answer was flagged and every unflagged answer was right.
AMBIGUOUS_MARGIN = 0.3251


@dataclass(frozen=True, eq=False)
class Registration:
    """One registration's answer; lengths in the caller's unit.

    Attributes:
        T_template_camera: (4, 4) estimated pose, ``p_template = R p_camera + t``, in the
            caller's template frame and unit.
        score: the method's own final score of that pose (lower is better): ours with a depth
            frame its depth-check cost, otherwise a distance in the object-normalised unit (times
            ``scale`` for the caller's unit) for ours and the correspondence baselines, ICP
            ``1 - fitness``.
        candidates: (K, 4, 4) every hypothesis the method scored before choosing, as
            ``T_template_camera`` in the caller's frame and unit (ours: one per partial template,
            before its final refinement; ICP: one per start). With ``up=None`` and a method that
            needs gravity, the candidates of every up hypothesis, concatenated.
        candidate_scores: (K,) their scores (lower is better, inf: excluded by the method).
        method: the method's config name (or class name for an instance).
        scale: the template radius in the caller's unit (one object-normalised unit).
        up_camera: (3,) the up direction used, camera frame (given, fitted to a frame's table, or
            the best hypothesis of the search), or None when the method used none.
        extras: the method's extras (timings, chosen template index, ...), ``ground_source``
            (``given``, ``plane`` or ``search``), a frame's ``visible_pixels`` and
            ``ground_inliers`` and, after an up search, ``up_search`` (hypotheses and scores).
        runtime_s: wall-clock seconds of the method call(s), preparation excluded.
        T_normalised: (4, 4) the method's own answer, in the object-normalised frames (what
            ``bench run`` stores as ``T_est``).
        runner_up: (4, 4) the pose that came closest to being the answer while differing from
            it by more than 10 degrees (ours with a depth frame: the best such pose of its last
            comparisons, typically a near-symmetric object's half turn), in the caller's frame and
            unit; None when the method names none.
        runner_up_margin: the runner-up's score minus the answer's (ours: depth-check cost per
            mask pixel, >= 0); near 0 the depth image barely told the two apart, so the answer
            is a guess between them that another cue (colour, a second view) should settle; NaN
            without a runner-up.
        ambiguous: the runner-up margin is below :data:`AMBIGUOUS_MARGIN`: the depth image
            barely chose between the answer and :attr:`runner_up`, so treat the answer as one of
            the two (ours with a depth frame names a runner-up; otherwise False).
    """

    T_template_camera: np.ndarray
    score: float
    candidates: np.ndarray
    candidate_scores: np.ndarray
    method: str
    scale: float
    up_camera: np.ndarray | None
    extras: Mapping[str, Any] = field(default_factory=dict)
    runtime_s: float = float("nan")
    T_normalised: np.ndarray | None = None
    runner_up: np.ndarray | None = None
    runner_up_margin: float = float("nan")

    @property
    def ambiguous(self) -> bool:
        """True when a runner-up lost by less than :data:`AMBIGUOUS_MARGIN` (see the class doc)."""
        return self.runner_up is not None and bool(self.runner_up_margin < AMBIGUOUS_MARGIN)

    def doubt(self) -> str | None:
        """One line saying why to doubt the answer (:attr:`ambiguous`), or None."""
        if not self.ambiguous:
            return None
        return (
            f"ambiguous: the runner-up pose (Registration.runner_up) lost by a margin of "
            f"{self.runner_up_margin:.4f} < {AMBIGUOUS_MARGIN}; the depth image barely told them apart, "
            "so check both (catpose.overlay draws them) or settle it with another cue (an object known "
            "to stand on the template's up: resting={'max_poses': 0}, docs/real-scenes.md)"
        )
