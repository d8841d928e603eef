"""Choosing one of a view's K template registrations without ground truth (``protocol.choice``).

The ``templates`` protocol registers every view to each of its category's K templates; a real
system then has to keep one estimate. The rules (``protocol.choice=<name>``):

- ``score``: the registration with the lowest method
  ``score``; views whose scores are all NaN keep the first template's.
- ``density``: the score less ``DENSITY_WEIGHT`` times the template's point spacing (median
  distance of a template point to its nearest neighbour, ``info["template_spacing"]``, written by
  the protocol): a Chamfer-type score cannot fall below what the template's sampling density
  leaves, and sparser templates would otherwise lose for their density alone (the fit
  normalised by template density; all templates share the unit-sphere size).
- ``agreement``: the templates share the category's canonical frame, so the K estimates of a
  view should agree when they are right, while wrong ones scatter. Each registration's support is
  the number of the view's other registrations whose rotation lies within ``AGREE_DEG`` of its
  own; the most supported wins, ties broken by the lowest score (with no agreement at all this is
  the ``score`` rule).

- ``cross`` (the ModelNet40 airplane and any-root experiments' rule): each registration's estimate is also checked on the view's other
  templates (:mod:`catpose.bench.protocols.cross_check`, ``info["cross_costs"]``, written by the
  protocol after each registration): its cost is its own template's cost (visibility-aware Chamfer
  distance plus a silhouette term) plus ``CROSS_WEIGHT`` times the mean over the other templates
  (each after a short ICP); the lowest wins. A right pose fits every template of the category; a turned pose that fits its
  own template by a shape coincidence does not. Registrations without costs (their check failed)
  are chosen only when no registration of the view has them (then by ``score``).
- ``cross_top`` (the ModelNet40 chair experiments' rule): the ``cross`` cost plus ``TOP_WEIGHT``
  times the estimate's top offset (``info["top_offset"]``,
  :func:`~catpose.bench.protocols.cross_check.top_offset`: how far across the vertical the view's
  highest part, posed by the estimate, stands from where the K templates put theirs). A chair
  turned a quarter puts its back at its side. It needs a category whose templates agree on where
  their top part stands: on the shared airplanes (biplanes' upper wings, high wings, tail fins)
  it chooses worse than ``cross``.

- ``cross_top_turns``: the ``cross_top`` cost, now over each registration and its turned
  candidates (``info["turns"]``, :func:`~catpose.bench.protocols.cross_check.turn_candidates`:
  the estimate turned a quarter each way about the template's up and refined on its own template).
  The chosen row is the registration's, its ``T_est`` and errors those of the candidate kept, and
  ``info["turn_deg"]`` the turn (0: the registration's own estimate); so, unlike the other rules,
  it can end better than the oracle (the best of the K registrations' own estimates).
- ``fused`` (the ModelNet40 chair K-template experiment's rule): the ``cross_top_turns`` choice
  with the top offset weighted ``FUSED_TOP_WEIGHT`` (not ``TOP_WEIGHT``: the weight chosen under
  this rule), then its pose averaged with those of the other templates that agree with it
  (:func:`fuse_agreeing`): for each other template, its lowest-cost candidate (registration or
  turn) whose rotation lies within ``AGREE_DEG`` of the chosen one's; the rotations are averaged
  (:meth:`scipy.spatial.transform.Rotation.mean`) and so are the translations. Each template's
  shape pulls a right registration a few degrees its own way; the average of the agreeing ones
  stands nearer the category's frame. ``info["fused_templates"]`` is how many poses were averaged
  (1: none agreed, the ``cross_top_turns`` pose is kept). Like ``cross_top_turns``, it can end
  better than the oracle.

Failed registrations are never chosen unless every registration of the view failed (then the
first row, a 180-degree error, is kept). Measurements behind the rules and their settings are in
docs/category-level.md.

Also here: :func:`is_excluded_view` (``protocol.exclude_templates``: a template instance's own
views are not test views; ``protocol.exclude_instances``) and :func:`random_choice_rows` (what a random choice would score).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.errors import ConfigError

CHOICES = ("score", "density", "agreement", "cross", "cross_top", "cross_top_turns", "fused")
#: ``cross``: own-template cost + CROSS_WEIGHT x mean cost on the other templates (chosen on the
#: development chairs and airplanes, docs/category-level.md)
CROSS_WEIGHT = 0.25
#: ``cross_top`` and ``cross_top_turns``: weight of the top offset (chosen for ``cross_top`` on the
#: real development chairs, docs/category-level.md)
TOP_WEIGHT = 0.05
#: ``fused``: weight of the top offset (chosen under ``fused`` itself on the procedural chairs,
#: confirmed on the real development chairs: results/category/dev/chair_*_fuse_weight.md)
FUSED_TOP_WEIGHT = 0.075
#: the rules that read the cross check, and the weight each gives the top offset (None: not read)
CROSS_RULES = {"cross": None, "cross_top": TOP_WEIGHT, "cross_top_turns": TOP_WEIGHT, "fused": FUSED_TOP_WEIGHT}
#: the rules that also choose among each registration's turned candidates (``info["turns"]``)
TURN_RULES = ("cross_top_turns", "fused")
#: the rules that average the chosen pose with the agreeing poses of the other templates
FUSE_RULES = ("fused",)
#: two registrations of a view agree when their rotations differ by at most this (degrees; also
#: ``fused``'s, chosen on the procedural chairs, docs/category-level.md)
AGREE_DEG = 20.0
#: ``density``: score - DENSITY_WEIGHT * template spacing (chosen on airplanes, docs/category-level.md)
DENSITY_WEIGHT = 1.5


def template_sample_id(obs_id: str, k: int) -> str:
    """The templates protocol's sample id of view ``obs_id`` against its ``k``-th template."""
    return f"{obs_id}|{k}"


def split_template_sample_id(sample_id: str) -> tuple[str, int]:
    """(view id, template index) of a :func:`template_sample_id`."""
    obs_id, _, k = str(sample_id).rpartition("|")
    return obs_id, int(k)


def check_choice(choice: str) -> str:
    """``choice`` if it names a rule, else a one-line :class:`ConfigError`."""
    if choice not in CHOICES:
        raise ConfigError(f"protocol.choice={choice!r} is unknown; use one of {', '.join(CHOICES)}")
    return choice


def is_excluded_view(obs_id: str, templates: Sequence[Any], instances: Sequence[str] = ()) -> bool:
    """Whether the view ``obs_id`` (``<category>/<instance_id>/v<k>``, the ModelNet loaders'
    ids) shows one of ``templates`` (template ids ``<dataset>/<instance_id>``) or one of
    ``instances`` (instance ids). Ids of another form never match."""
    parts = obs_id.split("/")
    if len(parts) != 3:
        return False
    return parts[1] in instances or any(str(t.template_id).rsplit("/", 1)[-1] == parts[1] for t in templates)


def _rotation(T_est: Any) -> np.ndarray | None:
    if T_est is None or (isinstance(T_est, float) and np.isnan(T_est)):
        return None
    return np.asarray(T_est, float).reshape(4, 4)[:3, :3]


def rotation_angle_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Geodesic angle (degrees) between two rotations (3, 3)."""
    c = (np.trace(R_a.T @ R_b) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def support(rotations: Sequence[np.ndarray], agree_deg: float = AGREE_DEG) -> np.ndarray:
    """(K,) for each rotation, how many of the others lie within ``agree_deg`` of it."""
    K = len(rotations)
    out = np.zeros(K, int)
    for a in range(K):
        for b in range(K):
            if a != b and rotation_angle_deg(rotations[a], rotations[b]) <= agree_deg:
                out[a] += 1
    return out


def choose_index(
    scores: Sequence[float],
    rotations: Sequence[np.ndarray | None],
    choice: str,
    agree_deg: float = AGREE_DEG,
    spacings: Sequence[float] | None = None,
    cross: Sequence[float] | None = None,
) -> int:
    """Index of the chosen registration among K (``rotations[k]`` None: failed; ``spacings``:
    the templates' point spacings, needed by ``density``; ``cross``: each registration's
    :func:`~catpose.bench.protocols.cross_check.cross_cost`, NaN where it has none, needed by
    ``cross``).

    Raises:
        ConfigError: unknown ``choice``, or ``density`` without spacings.
    """
    check_choice(choice)
    ok = [k for k, R in enumerate(rotations) if R is not None]
    if not ok:
        return 0
    s = np.array([scores[k] for k in ok], float)
    if choice in CROSS_RULES:
        c = np.array([np.nan if cross is None else cross[k] for k in ok], float)
        if np.isfinite(c).any():
            s = np.where(np.isfinite(c), c, np.inf)
    if choice == "density":
        sp = np.array([np.nan if spacings is None else spacings[k] for k in ok], float)
        if not np.isfinite(sp).all():
            raise ConfigError(
                "protocol.choice=density needs info.template_spacing in every row; these rows "
                "were written before it existed: re-run them, or use protocol.choice=score"
            )
        s = s - DENSITY_WEIGHT * sp
    s = np.where(np.isfinite(s), s, np.inf)
    if choice == "agreement":
        sup = support([rotations[k] for k in ok], agree_deg)
        order = sorted(range(len(ok)), key=lambda a: (-sup[a], s[a], a))
    else:
        order = sorted(range(len(ok)), key=lambda a: (s[a], a))
    return ok[order[0]]


def choose_row(group, choice: str = "score", top_weight: float | None = None, fuse_deg: float | None = None):
    """The chosen row (a pandas Series) of one view's registrations (``group``: the view's rows of
    ``samples.jsonl`` as a DataFrame, one per template); ``top_weight``: another weight of the top
    offset than ``cross_top``'s, ``fuse_deg``: another agreement angle than ``fused``'s
    ``AGREE_DEG`` (the development grids)."""
    import pandas as pd

    status_ok = (group["status"] == "ok").to_numpy()
    scores = pd.to_numeric(group["score"], errors="coerce").to_numpy(float)
    if choice != "agreement" and "T_est" not in group:  # rows from files without estimates
        rotations = [np.eye(3) if good else None for good in status_ok]
    else:
        rotations = [(_rotation(T) if good else None) for T, good in zip(group["T_est"], status_ok)]
    spacings = cross = None
    if choice in CROSS_RULES and len(group) > 1:  # one template: nothing to choose, no costs written
        weight = CROSS_RULES[choice]
        cross = cross_costs_of(group, top_weight if weight is not None and top_weight is not None else weight)
    if choice == "density":
        infos = group["info"] if "info" in group else [{}] * len(group)
        spacings = [float(i.get("template_spacing", np.nan)) if isinstance(i, dict) else np.nan for i in infos]
    # one template: the estimate or one of its turns, where the run stored them (else nothing to choose)
    if choice in TURN_RULES and (len(group) > 1 or has_turns(group)):
        row = _with_best_turn(
            group,
            top_weight if top_weight is not None else CROSS_RULES[choice],
            choice,
            (AGREE_DEG if fuse_deg is None else fuse_deg) if choice in FUSE_RULES else None,
        )
        if row is not None:
            return row
    return group.iloc[choose_index(list(scores), rotations, choice, spacings=spacings, cross=cross)]


def has_turns(group) -> bool:
    """Whether any row of ``group`` (rows of ``samples.jsonl``) carries ``info["turns"]``."""
    return "info" in group and any(isinstance(i, dict) and i.get("turns") for i in group["info"])


def rule_candidates(
    group, top_weight: float, choice: str = "cross_top_turns"
) -> list[tuple[tuple[float, int, int], int, Any]]:
    """Every candidate a turn rule chooses among in one view's rows (``group``): each ok row's
    registration and its turned candidates (``info["turns"]``) with a finite ``cross_top`` cost
    (top offset weighted ``top_weight``). Returns ``((cost, row position, candidate: -1 the
    registration's own estimate, else the turn's index), own template index, pose)`` tuples, the
    pose as stored ((4, 4) or nested lists).

    Raises:
        ConfigError: no ok row has ``info.turns`` (rows written before them, or ``protocol.turns=[]``).
    """
    from catpose.bench.protocols.cross_check import cross_cost

    status_ok = (group["status"] == "ok").to_numpy()
    candidates: list[tuple[tuple[float, int, int], int, Any]] = []
    seen_turns = False
    for pos, (info, sample_id, good, T_est) in enumerate(
        zip(
            group["info"] if "info" in group else [{}] * len(group),
            group["sample_id"],
            status_ok,
            group["T_est"] if "T_est" in group else [None] * len(group),
        )
    ):
        if not good or not isinstance(info, dict) or not info.get("cross_costs") or info.get("top_offset") is None:
            continue
        own = split_template_sample_id(sample_id)[1]
        turns = info.get("turns") or []
        seen_turns = seen_turns or bool(turns)
        for c, (costs, top, T) in enumerate(
            [(info["cross_costs"], info["top_offset"], T_est)]
            + [(t["cross_costs"], t["top_offset"], t["T_template_camera"]) for t in turns]
        ):
            key = (cross_cost(costs, own, CROSS_WEIGHT, top, top_weight), pos, c - 1)
            if np.isfinite(key[0]):
                candidates.append((key, own, T))
    if (
        status_ok.any()
        and not seen_turns
        and not any(
            isinstance(i, dict) and "estimate_facts_error" in i for i in (group["info"] if "info" in group else [])
        )
    ):
        raise ConfigError(
            f"protocol.choice={choice} needs info.turns (written by the templates protocol after "
            "each registration unless protocol.turns=[]); these rows have none: run them again into a "
            "new output_root, or use protocol.choice=cross_top"
        )
    return candidates


def _with_best_turn(group, top_weight: float, choice: str = "cross_top_turns", fuse_deg: float | None = None):
    """``cross_top_turns``: the row whose registration or turned candidate has the lowest
    ``cross_top`` cost (:func:`rule_candidates`), carrying that candidate's ``T_est``, errors and
    ``info["turn_deg"]``; with ``fuse_deg`` (``fused``), its pose then averaged with the agreeing
    candidates of the other rows (:func:`fuse_agreeing`, ``info["fused_templates"]``). None when
    no row has costs (its check failed: the rule falls back to the score).

    Raises:
        ConfigError: no ok row has ``info.turns`` (rows written before them, or ``protocol.turns=[]``).
    """
    candidates = rule_candidates(group, top_weight, choice)
    if not candidates:
        return None
    (_, pos, cand), own, T_best = min(candidates, key=lambda c: c[0])
    row = group.iloc[pos].copy()
    info = dict(row["info"])
    info["turn_deg"] = 0.0 if cand < 0 else float(info["turns"][cand]["turn_deg"])
    T_est = None if cand < 0 else np.asarray(T_best, float)
    if fuse_deg is not None and _rotation(T_best) is not None:
        others = [
            (k, key[0], np.asarray(T, float)) for key, k, T in candidates if key[1] != pos and _rotation(T) is not None
        ]
        T_fused, n = fuse_agreeing(np.asarray(T_best, float).reshape(4, 4), others, fuse_deg)
        info["fused_templates"] = n
        if n > 1:
            T_est = T_fused
    row["info"] = info
    if T_est is not None:
        _set_estimate(row, T_est)
    return row


def _set_estimate(row, T_est: np.ndarray) -> None:
    """Give the chosen ``row`` the estimate ``T_est`` (4, 4) and its errors (where it has a ``T_gt``)."""
    from catpose.bench.scoring.metrics import sample_errors

    T_est = np.asarray(T_est, float).reshape(4, 4)
    row["T_est"] = T_est.tolist()
    if isinstance(row.get("T_gt"), (list, np.ndarray)):
        axis, syms = row.get("symmetry_axis"), row.get("symmetries")
        for key, value in sample_errors(
            T_est,
            np.reshape(row["T_gt"], (4, 4)),
            np.asarray(axis, float) if isinstance(axis, (list, np.ndarray)) else None,
            syms if isinstance(syms, (list, tuple)) else (),
        ).items():
            row[key] = value


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


def cross_costs_of(group, top_weight: float | None = None) -> list[float]:
    """Each row's ``cross`` cost (NaN where its ``info`` has no ``cross_costs``); with a
    ``top_weight``, the ``cross_top`` cost with the top offset weighted so (NaN also where the row
    has no ``top_offset``).

    Raises:
        ConfigError: no row of the group has them (rows written before the check existed).
    """
    from catpose.bench.protocols.cross_check import cross_cost

    infos = group["info"] if "info" in group else [{}] * len(group)
    out = []
    for info, sample_id in zip(infos, group["sample_id"]):
        costs = info.get("cross_costs") if isinstance(info, dict) else None
        offset = (0.0 if top_weight is None else info.get("top_offset")) if costs else None
        own = split_template_sample_id(sample_id)[1] if costs else 0
        out.append(
            cross_cost(costs, own, CROSS_WEIGHT, offset, top_weight or 0.0) if costs and offset is not None else np.nan
        )
    status_ok = (group["status"] == "ok").to_numpy() if "status" in group else np.ones(len(group), bool)
    if (
        status_ok.any()
        and not np.isfinite(np.asarray(out, float)[status_ok]).any()
        and not any(isinstance(i, dict) and "estimate_facts_error" in i for i in infos)
    ):
        top = top_weight is not None
        needs = "info.cross_costs and info.top_offset" if top else "info.cross_costs"
        raise ConfigError(
            f"protocol.choice={'cross_top' if top else 'cross'} needs {needs} (written by the templates "
            "protocol after each registration); these rows predate them: run them again into a new output_root (a run "
            "resumes its finished rows), or use protocol.choice=score"
        )
    return out


_SPACING: dict[str, float] = {}


def template_spacing(template: Any) -> float:
    """Median distance (object-normalised unit) from each point of ``template.points`` (M, 3) to
    its nearest neighbour, cached by template id."""
    key = f"{template.template_id}#{len(template.points)}"
    if key not in _SPACING:
        from scipy.spatial import cKDTree

        pts = np.asarray(template.points, float)
        _SPACING[key] = float(np.median(cKDTree(pts).query(pts, k=2)[0][:, 1])) if len(pts) > 1 else float("nan")
    return _SPACING[key]


def with_template_facts(sample: Any) -> Any:
    """``sample`` with ``info["template_spacing"]`` (:func:`template_spacing` of its template)."""
    import dataclasses

    info = dict(sample.info)
    info["template_spacing"] = template_spacing(sample.problem.template)
    return dataclasses.replace(sample, info=info)


def random_choice_rows(samples):
    """The rows a uniformly random choice could return: every registration of every view that
    has at least one, each weighted ``1 / K_view`` (a DataFrame with a ``weight`` column), so
    weighted statistics are the expected statistics of choosing a template at random."""
    out = samples.copy()
    out["weight"] = 1.0 / out.groupby("group_id")["group_id"].transform("size")
    return out
