"""The rules that keep one of a view's K template registrations without ground truth (``choice=<rule>``).

:func:`choose` applies a :class:`ChoiceRule` to a view's K :class:`TemplateEstimate` s (pose, the
method's score, the facts :class:`catpose.methods.template_choice.TemplateChoice` computed after
the registration) and returns a :class:`Choice`. Each cross rule extends the one before it:

- ``score``: the lowest method score (all NaN: the first template's).
- ``density``: the score less ``density_weight`` times the template's point spacing
  (:func:`template_spacing`): a Chamfer-type score cannot fall below what the template's sampling
  leaves, so sparser templates would otherwise lose for their density alone.
- ``agreement``: the estimate with the most others within ``agree_deg`` of its rotation (the
  templates share the category's frame: right estimates agree, wrong ones scatter), then the score.
- ``cross``: own template's cost plus ``cross_weight`` times the mean cost on the other templates
  (facts ``cross_costs``, :mod:`catpose.methods.cross_check`); estimates without costs are chosen
  only when none has them (then by ``score``).
- ``cross_top``: ``cross`` plus ``top_weight`` times the top offset (facts ``top_offset``: how far
  across the vertical the view's highest part stands from where the templates put theirs).
- ``cross_top_turns``: ``cross_top`` over each estimate and its turned candidates (facts
  ``turns``); ``Choice.turn_deg`` is the turn kept, so it can beat the best registration.
- ``fused``: ``cross_top_turns`` with the offset weighted ``fused_top_weight``, its pose then
  averaged with each other template's lowest-cost candidate within ``agree_deg``
  (:func:`fuse_agreeing`).

A failed registration is chosen only when all failed (the first is kept). Kept whole because the
rules are one ladder over shared costs, which the protocols apply to stored facts as one import;
only NumPy and SciPy, no registration runs here. How the weights were chosen:
docs/category-level.md, docs/choosing-defaults.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from catpose.content_hash import content_hash
from catpose.errors import ConfigError

RULES = ("score", "density", "agreement", "cross", "cross_top", "cross_top_turns", "fused")
#: the rules that read the cross check (``cross_costs``)
CROSS_RULES = RULES[3:]
#: the rules that also choose among each registration's turned candidates (``turns``)
TURN_RULES = ("cross_top_turns", "fused")
#: the rules that average the chosen pose with the agreeing poses of the other templates
FUSE_RULES = ("fused",)
#: the :class:`ChoiceRule` field that weights the top offset, by rule (the others read none)
OFFSET_FIELDS = {"cross_top": "top_weight", "cross_top_turns": "top_weight", "fused": "fused_top_weight"}
#: the default rule (configs/run.yaml's `choice`; a test asserts they agree), chosen on the
#: development tables (experiments/category_choice/README.md)
DEFAULT_RULE = "fused"

#: the defaults of :class:`ChoiceRule` (configs/choice/score.yaml is the source; a test asserts
#: they agree): the cross rules' weight of the mean cost on the other templates
CROSS_WEIGHT = 0.25
#: ``cross_top`` and ``cross_top_turns``: weight of the top offset (per object-normalised unit)
TOP_WEIGHT = 0.05
#: ``fused``: weight of the top offset (per object-normalised unit)
FUSED_TOP_WEIGHT = 0.075
#: ``agreement`` and ``fused``: two rotations agree within this (degrees)
AGREE_DEG = 20.0
#: ``density``: score - DENSITY_WEIGHT * template spacing
DENSITY_WEIGHT = 1.5


def check_rule(rule: str) -> str:
    """``rule`` if it names a rule, else a one-line :class:`ConfigError`."""
    if rule not in RULES:
        raise ConfigError(f"choice={rule!r} is unknown; use one of {', '.join(RULES)}")
    return rule


@dataclass(frozen=True)
class ChoiceRule:
    """A rule of :data:`RULES` and its weights (the constants above)."""

    rule: str = DEFAULT_RULE
    cross_weight: float = CROSS_WEIGHT
    top_weight: float = TOP_WEIGHT
    fused_top_weight: float = FUSED_TOP_WEIGHT
    agree_deg: float = AGREE_DEG
    density_weight: float = DENSITY_WEIGHT

    def __post_init__(self) -> None:
        check_rule(self.rule)

    @property
    def offset_weight(self) -> float | None:
        """The weight this rule gives the top offset (None: it reads none)."""
        key = OFFSET_FIELDS.get(self.rule)
        return None if key is None else getattr(self, key)


@dataclass(frozen=True, eq=False)
class TemplateEstimate:
    """One registration of a view on its template ``template_index`` (0 <= k < K), as the rules
    read it: ``T_template_camera`` (4, 4) or None, the method's ``score`` (lower is better; NaN:
    none), ``ok`` (succeeded), and ``facts``: :meth:`~catpose.methods.template_choice.TemplateChoice.estimate_facts`'
    ``cross_costs`` (K,), ``top_offset``, ``turns`` (dicts ``turn_deg``, ``T_template_camera``,
    ``cross_costs``, ``top_offset``), ``estimate_facts_error`` (why they are missing), and
    ``template_spacing``."""

    template_index: int
    T_template_camera: np.ndarray | None
    score: float = float("nan")
    facts: Mapping[str, Any] = field(default_factory=dict)
    ok: bool = True


class Choice(NamedTuple):
    """What :func:`choose` keeps: the registration's ``position`` among the estimates and its
    ``template_index``; the kept pose ``T_template_camera`` (4, 4; its own, a turn, or the fused
    pose; None when it has none); ``turn_deg`` (0: its own estimate; None: the rule reads no
    turns); ``fused_templates`` (``fused``: poses averaged, 1: none agreed; else None);
    ``pose_changed`` (a turn or a fusion); the ``estimates`` chosen among."""

    position: int
    template_index: int
    T_template_camera: np.ndarray | None
    turn_deg: float | None
    fused_templates: int | None
    pose_changed: bool
    estimates: tuple[TemplateEstimate, ...]


def rotation_angle_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Geodesic angle (degrees) between two rotations (3, 3)."""
    c = (np.trace(R_a.T @ R_b) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def support(rotations: Sequence[np.ndarray], agree_deg: float = AGREE_DEG) -> np.ndarray:
    """(K,) for each rotation, how many of the others lie within ``agree_deg`` of it."""
    K = len(rotations)
    near = [
        [a != b and rotation_angle_deg(rotations[a], rotations[b]) <= agree_deg for b in range(K)] for a in range(K)
    ]
    return np.array([sum(row) for row in near], int)


def cross_cost(costs: Sequence[float], own: int, weight: float, top: float = 0.0, top_weight: float = 0.0) -> float:
    """One estimate's ``cross`` cost from its ``cross_costs`` (K,): its own template's cost plus
    ``weight`` times the mean of the other templates' (the own cost alone when K = 1), plus
    ``top_weight`` times its top offset ``top``."""
    c = np.asarray(costs, float)
    others = np.delete(c, own)
    return float(c[own] + (weight * others.mean() if len(others) else 0.0) + top_weight * float(top))


def _facts_cost(facts: Mapping[str, Any], own: int, cross_weight: float, offset_weight: float | None) -> float:
    """:func:`cross_cost` of one candidate's ``facts`` (``cross_costs``, and ``top_offset`` weighted
    ``offset_weight`` unless None); NaN where they are missing."""
    costs = facts.get("cross_costs")
    top = 0.0 if offset_weight is None else facts.get("top_offset")
    if costs is None or not len(costs) or top is None:
        return np.nan
    return cross_cost(costs, own, cross_weight, top, offset_weight or 0.0)


def choose_index(
    scores: Sequence[float],
    rotations: Sequence[np.ndarray | None],
    choice: str,
    agree_deg: float = AGREE_DEG,
    spacings: Sequence[float] | None = None,
    cross: Sequence[float] | None = None,
    density_weight: float = DENSITY_WEIGHT,
) -> int:
    """Index of the chosen registration among K by the rules that keep a registration's own pose
    (``rotations[k]`` None: failed; ``spacings``: the templates' point spacings, needed by
    ``density``; ``cross``: each registration's cross cost (:func:`cross_costs_of`), NaN where it
    has none, read by the cross rules).

    Raises:
        ConfigError: unknown ``choice``, or ``density`` without spacings.
    """
    check_rule(choice)
    ok = [k for k, R in enumerate(rotations) if R is not None]
    if not ok:
        return 0
    s = np.array([scores[k] for k in ok], float)
    c = np.array([np.nan if cross is None else cross[k] for k in ok], float)
    if choice in CROSS_RULES and np.isfinite(c).any():
        s = np.where(np.isfinite(c), c, np.inf)
    if choice == "density":
        sp = np.array([np.nan if spacings is None else spacings[k] for k in ok], float)
        if not np.isfinite(sp).all():
            raise ConfigError(
                "choice=density needs info.template_spacing in every row; these rows "
                "were written before it existed: re-run them, or use choice=score"
            )
        s = s - density_weight * sp
    s = np.where(np.isfinite(s), s, np.inf)
    if choice == "agreement":
        sup = support([rotations[k] for k in ok], agree_deg)
        return ok[min(range(len(ok)), key=lambda a: (-sup[a], s[a], a))]
    return ok[int(np.argmin(s))]  # the first of the lowest


def _has_facts_error(estimates: Sequence[TemplateEstimate]) -> bool:
    return any("estimate_facts_error" in e.facts for e in estimates)


def cross_costs_of(
    estimates: Sequence[TemplateEstimate], cross_weight: float, offset_weight: float | None
) -> list[float]:
    """Each estimate's ``cross`` cost (NaN where it has no ``cross_costs``); with an
    ``offset_weight``, the ``cross_top`` cost with the top offset weighted so (NaN also where it
    has no ``top_offset``).

    Raises:
        ConfigError: no ok estimate has them (rows written before the check existed).
    """
    out = [_facts_cost(e.facts, e.template_index, cross_weight, offset_weight) for e in estimates]
    status_ok = np.array([e.ok for e in estimates], bool)
    if status_ok.any() and not np.isfinite(np.asarray(out, float)[status_ok]).any() and not _has_facts_error(estimates):
        top = offset_weight is not None
        needs = "info.cross_costs and info.top_offset" if top else "info.cross_costs"
        raise ConfigError(
            f"choice={'cross_top' if top else 'cross'} needs {needs} (computed after each registration "
            "of a templates run); these rows predate them: run them again into a new output_root (a run "
            "resumes its finished rows), or use choice=score"
        )
    return out


def turn_candidates_of(
    estimates: Sequence[TemplateEstimate], cross_weight: float, offset_weight: float, rule: str = "cross_top_turns"
) -> list[tuple[tuple[float, int, int], int, Any]]:
    """Every candidate a turn rule chooses among: each ok estimate and its turned candidates
    (facts ``turns``) with a finite ``cross_top`` cost (top offset weighted ``offset_weight``).
    Returns ``((cost, position, candidate: -1 the registration's own estimate, else the turn's
    index), own template index, pose)`` tuples, the pose as given ((4, 4) or nested lists).

    Raises:
        ConfigError: no ok estimate has turns (rows written before them, or ``choice.turns_deg=[]``).
    """
    candidates: list[tuple[tuple[float, int, int], int, Any]] = []
    seen_turns = False
    for pos, e in enumerate(estimates):
        if not e.ok or not e.facts.get("cross_costs") or e.facts.get("top_offset") is None:
            continue
        turns = e.facts.get("turns") or []
        seen_turns = seen_turns or bool(turns)
        for c, facts in enumerate([{**e.facts, "T_template_camera": e.T_template_camera}, *turns]):
            key = (_facts_cost(facts, e.template_index, cross_weight, offset_weight), pos, c - 1)
            if np.isfinite(key[0]):
                candidates.append((key, e.template_index, facts["T_template_camera"]))
    if any(e.ok for e in estimates) and not seen_turns and not _has_facts_error(estimates):
        raise ConfigError(
            f"choice={rule} needs info.turns (computed after each registration of a templates run "
            "unless choice.turns_deg=[]); these rows have none: run them again into a new output_root, "
            "or use choice=cross_top"
        )
    return candidates


def fuse_agreeing(
    T_chosen: np.ndarray, others: Sequence[tuple[int, float, np.ndarray]], agree_deg: float = AGREE_DEG
) -> tuple[np.ndarray, int]:
    """The chosen pose ``T_chosen`` (4, 4, camera -> the category's template frame) averaged with,
    for each other template, its lowest-cost pose among ``others`` ((template index, cost, (4, 4)
    pose) each) whose rotation lies within ``agree_deg`` degrees of the chosen one's. Rotations
    are averaged by :meth:`scipy.spatial.transform.Rotation.mean` (the chordal mean of unit
    quaternions), translations by their arithmetic mean. Returns the pose (4, 4) and how many
    poses were averaged (1: none agreed, and the pose is ``T_chosen``)."""
    from scipy.spatial.transform import Rotation

    T_chosen = np.asarray(T_chosen, float).reshape(4, 4)
    best: dict[int, tuple[float, np.ndarray]] = {}
    for k, cost, T in others:
        T = np.asarray(T, float).reshape(4, 4)
        if rotation_angle_deg(T_chosen[:3, :3], T[:3, :3]) <= agree_deg and (k not in best or cost < best[k][0]):
            best[k] = (float(cost), T)
    if not best:
        return T_chosen.copy(), 1
    poses = [T_chosen] + [best[k][1] for k in sorted(best)]
    out = np.eye(4)
    out[:3, :3] = Rotation.from_matrix(np.stack([T[:3, :3] for T in poses])).mean().as_matrix()
    out[:3, 3] = np.mean([T[:3, 3] for T in poses], axis=0)
    return out, len(poses)


def _pose(T: Any) -> np.ndarray | None:
    return None if T is None else np.asarray(T, float).reshape(4, 4)


def _best_turn(estimates: tuple[TemplateEstimate, ...], rule: ChoiceRule) -> Choice | None:
    """The turn rules: the estimate or turned candidate with the lowest ``cross_top`` cost
    (:func:`turn_candidates_of`); under ``fused`` its pose then averaged with the agreeing
    candidates of the other estimates. None when no estimate has costs (the rule falls back to
    the score)."""
    candidates = turn_candidates_of(estimates, rule.cross_weight, rule.offset_weight, rule.rule)
    if not candidates:
        return None
    (_, pos, cand), own, T_best = min(candidates, key=lambda c: c[0])
    turn_deg = 0.0 if cand < 0 else float(estimates[pos].facts["turns"][cand]["turn_deg"])
    T_kept, fused = _pose(T_best), None
    if rule.rule in FUSE_RULES and T_kept is not None:
        others = [(k, key[0], _pose(T)) for key, k, T in candidates if key[1] != pos and T is not None]
        T_fused, fused = fuse_agreeing(T_kept, others, rule.agree_deg)
        if fused > 1:
            T_kept = T_fused
    changed = T_kept is not None and (cand >= 0 or (fused or 1) > 1)
    return Choice(pos, own, T_kept, turn_deg, fused, changed, estimates)


def choose(estimates: Sequence[TemplateEstimate], rule: ChoiceRule) -> Choice:
    """The estimate ``rule`` keeps among one view's ``estimates`` (at least one), and its pose.

    Raises:
        ConfigError: the rule needs facts the estimates do not carry (rows written before them).
    """
    estimates = tuple(estimates)
    if not estimates:
        raise ValueError("choose needs at least one estimate")
    name = rule.rule
    cross = None
    if name in CROSS_RULES and len(estimates) > 1:  # one template: nothing to choose, no costs
        cross = cross_costs_of(estimates, rule.cross_weight, rule.offset_weight)
    # one template: the estimate or one of its turns, where they were computed (else nothing to choose)
    if name in TURN_RULES and (len(estimates) > 1 or any(e.facts.get("turns") for e in estimates)):
        kept = _best_turn(estimates, rule)
        if kept is not None:
            return kept
    rotations = [
        (np.eye(3) if e.T_template_camera is None else _pose(e.T_template_camera)[:3, :3]) if e.ok else None
        for e in estimates
    ]
    spacings = [float(e.facts.get("template_spacing", np.nan)) for e in estimates] if name == "density" else None
    scores = [float(e.score) for e in estimates]
    pos = choose_index(scores, rotations, name, rule.agree_deg, spacings, cross, rule.density_weight)
    e = estimates[pos]
    return Choice(pos, e.template_index, _pose(e.T_template_camera), None, None, False, estimates)


_SPACING: dict[str, float] = {}


def template_spacing(template: Any) -> float:
    """Median distance (object-normalised unit) from each point of ``template.points`` (M, 3) to
    its nearest neighbour, cached by the template's content (the ``density`` rule's fact)."""
    key = f"{template.template_id}-{content_hash(np.asarray(template.points, float))}"
    if key not in _SPACING:
        from scipy.spatial import cKDTree

        pts = np.asarray(template.points, float)
        _SPACING[key] = float(np.median(cKDTree(pts).query(pts, k=2)[0][:, 1])) if len(pts) > 1 else float("nan")
    return _SPACING[key]
