"""A templates run's rows: their sample ids, the views left out, and the row each view keeps.

The ``templates`` protocol registers every view to each of its category's K templates, one row
each (sample id ``<obs_id>|<k>``). Which of a view's K estimates is kept is the method side's
choice (:mod:`catpose.methods.template_choice`, the ``choice`` config group): the runner stores its
facts in each row's ``info`` after the registration (``cross_costs``, ``top_offset``, ``turns``),
and :func:`choose_row` applies the same rule (:func:`catpose.methods.choice_rules.choose`) to what
the rows store; no registration runs here. The kept row carries the kept pose (a turn or a fused
pose: its ``T_est`` and errors replaced, ``info["turn_deg"]``, ``info["fused_templates"]``).

Also here: :func:`is_excluded_view` (``protocol.exclude_templates``: a template instance's own views
are not test views; ``protocol.exclude_instances``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.bench.scoring.rows import row_array
from catpose.methods.choice_rules import DEFAULT_RULE, ChoiceRule, TemplateEstimate, choose, template_spacing


def template_sample_id(obs_id: str, k: int) -> str:
    """The templates protocol's sample id of view ``obs_id`` against its ``k``-th template."""
    return f"{obs_id}|{k}"


def split_template_sample_id(sample_id: str) -> tuple[str, int]:
    """(view id, template index) of a :func:`template_sample_id`."""
    obs_id, _, k = str(sample_id).rpartition("|")
    return obs_id, int(k)


def is_excluded_view(obs_id: str, templates: Sequence[Any], instances: Sequence[str] = ()) -> bool:
    """Whether the view ``obs_id`` (``<category>/<instance_id>/v<k>``, the ModelNet loaders'
    ids) shows one of ``templates`` (template ids ``<dataset>/<instance_id>``) or one of
    ``instances`` (instance ids). Ids of another form never match."""
    parts = obs_id.split("/")
    if len(parts) != 3:
        return False
    return parts[1] in instances or any(str(t.template_id).rsplit("/", 1)[-1] == parts[1] for t in templates)


def as_rule(choice: str | ChoiceRule) -> ChoiceRule:
    """A rule name (its default weights) or a :class:`~catpose.methods.choice_rules.ChoiceRule` as the latter."""
    return choice if isinstance(choice, ChoiceRule) else ChoiceRule(rule=str(choice))


def estimates_of(group) -> list[TemplateEstimate]:
    """One view's rows (``group``: rows of ``samples.jsonl`` as a DataFrame, one per template) as the
    choice rules read them, in row order."""
    import pandas as pd

    status_ok = (group["status"] == "ok").to_numpy() if "status" in group else np.ones(len(group), bool)
    scores = (
        pd.to_numeric(group["score"], errors="coerce").to_numpy(float) if "score" in group else [np.nan] * len(group)
    )
    poses = [row_array(T) for T in group["T_est"]] if "T_est" in group else [None] * len(group)
    infos = group["info"] if "info" in group else [{}] * len(group)
    ids = group["sample_id"] if "sample_id" in group else [None] * len(group)
    return [
        TemplateEstimate(
            template_index=_template_index(sample_id, position),
            T_template_camera=T,
            score=float(score),
            facts=info if isinstance(info, dict) else {},
            # rows from files without estimates: an ok row is a registration all the same
            ok=bool(good) and (T is not None or "T_est" not in group),
        )
        for position, (sample_id, T, score, info, good) in enumerate(zip(ids, poses, scores, infos, status_ok))
    ]


def _template_index(sample_id: Any, position: int) -> int:
    """The template index of a templates run's sample id (``<obs_id>|<k>``); rows whose ids have
    another form (rows made by hand, external predictions) count in their order."""
    _, sep, k = str(sample_id).rpartition("|")
    return int(k) if sep and k.isdigit() else position


def choose_row(
    group, choice: str | ChoiceRule = DEFAULT_RULE, top_weight: float | None = None, fuse_deg: float | None = None
):
    """The row (a pandas Series) one view keeps among its registrations (``group``: the view's rows
    of ``samples.jsonl`` as a DataFrame, one per template) under ``choice`` (a rule name, with its
    default weights, or a :class:`~catpose.methods.choice_rules.ChoiceRule`); ``top_weight``:
    another weight of the top offset than the rule's, ``fuse_deg``: another agreement angle for
    ``fused`` (the development grids). A turn or a fused pose replaces the row's ``T_est`` and errors.

    Raises:
        ConfigError: the rule needs facts the rows do not store (written before them).
    """
    rule = as_rule(choice).with_offset_weight(top_weight)
    if fuse_deg is not None and rule.rule == "fused":
        rule = dataclasses.replace(rule, agree_deg=float(fuse_deg))
    kept = choose(estimates_of(group), rule)
    row = group.iloc[kept.position]
    if kept.turn_deg is None and kept.fused_templates is None:
        return row
    row = row.copy()
    info = dict(row["info"])
    info["turn_deg"] = kept.turn_deg
    if kept.fused_templates is not None:
        info["fused_templates"] = kept.fused_templates
    row["info"] = info
    if kept.pose_changed:
        _set_estimate(row, kept.T_template_camera)
    return row


def has_turns(group) -> bool:
    """Whether any row of ``group`` (rows of ``samples.jsonl``) carries ``info["turns"]``."""
    return "info" in group and any(isinstance(i, dict) and i.get("turns") for i in group["info"])


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


def with_template_facts(sample: Any) -> Any:
    """``sample`` with ``info["template_spacing"]`` (the ``density`` rule's fact of its template,
    :func:`catpose.methods.choice_rules.template_spacing`)."""
    info = dict(sample.info)
    info["template_spacing"] = template_spacing(sample.problem.template)
    return dataclasses.replace(sample, info=info)
