"""What :func:`catpose.register` and :class:`catpose.Registrar` return."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Registration"]


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
