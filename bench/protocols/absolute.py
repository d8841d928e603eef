"""Evaluation protocols: which problems are built from a dataset's observations and how their
per-sample errors are scored. The same protocol applies to every method, so every method is
scored on the same problems (fixed by dataset, protocol and seed alone).

- ``gt_model``: each partial view against its own complete model.
- ``templates``: each view against each of the category's K templates (one problem each, sample id
  ``<obs_id>|<k>``); the estimate of a view is the one the method side's choice keeps without
  ground truth (``choice=<rule>``, :mod:`catpose.methods.template_choice`), applied by
  :func:`choose_row` to the facts the runner stored in the rows (no registration runs here), and
  the paper's "minimum error across templates" is reported beside it as an oracle.
- ``relative`` (:mod:`catpose.bench.protocols.relative`): relative pose between two views of one object.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.bench.scoring.rows import row_array
from catpose.datasets.dataset import ObjectDataset, Observation
from catpose.errors import ConfigError, DatasetError
from catpose.methods.choice_rules import (
    CROSS_RULES,
    DEFAULT_RULE,
    TURN_RULES,
    ChoiceRule,
    TemplateEstimate,
    choose,
    template_spacing,
)
from catpose.types import GroundTruth, RegistrationProblem, Sample, Template


def make_sample(obs: Observation, template: Template, sample_id: str, group_id: str) -> Sample:
    """The problem of registering ``obs`` to ``template`` and its ground truth.

    Category-level alignment puts the template and the instance in one canonical frame, so
    ``T_template_camera = T_object_camera``.
    """
    problem = RegistrationProblem(
        sample_id=sample_id,
        category=obs.category,
        points_camera=obs.points_camera,
        normals_camera=obs.normals_camera,
        ground_normal_camera=obs.ground_normal_camera,
        template=template,
        depth_image=obs.depth_image,
    )
    gt = GroundTruth(
        T_template_camera=np.asarray(obs.T_object_camera, float),
        symmetry_axis=obs.symmetry_axis,
        symmetries=tuple(np.asarray(S, float) for S in obs.symmetries),
    )
    info = {"instance_id": obs.instance_id, "template_id": template.template_id, **dict(obs.info)}
    return Sample(problem=problem, gt=gt, group_id=group_id, info=info)


def require_consistent_frames(dataset: ObjectDataset, what: str) -> None:
    """Refuse a category-level protocol on a dataset whose instances' frames are not declared
    consistent (``dataset.frames_consistent``): a template's frame would differ from the
    observed instance's by an unknown rotation, and the errors would measure that rotation.

    Raises:
        ConfigError: one line naming the fixes.
    """
    if getattr(dataset, "frames_consistent", True):
        return
    raise ConfigError(
        f"{dataset.name}: {what} compares instances, but their frames are not declared "
        "consistent and dataset.alignment_table is unset; use dataset=modelnet40_aligned (the "
        "aligned release), or set dataset.alignment_table=<csv> (results/alignment/ holds the shared "
        "shapes' tables; experiments/alignment/align.py writes one)"
    )


class Protocol(ABC):
    """Builds samples from a dataset and turns per-sample rows into scored rows."""

    name: str = "protocol"

    @abstractmethod
    def sample_ids(self, dataset: ObjectDataset) -> list[str]:
        """Ids of every problem, in a fixed order."""

    @abstractmethod
    def load(self, dataset: ObjectDataset, sample_id: str) -> Sample:
        """Build one problem (raises :class:`~catpose.errors.CatposeError` on bad data)."""

    def score_units(self, samples):
        """Per-sample rows (the ``samples.jsonl`` schema) -> the rows the statistics count.

        Views whose dataset has no absolute ground truth (``info["absolute_gt"]`` False, e.g. a
        Redwood scan: only relative poses are known) are left out; use ``protocol=relative``.
        """
        return absolute_gt_only(samples)

    def _observation(self, dataset: ObjectDataset, obs_id: str) -> Observation:
        """``dataset.observation(obs_id)``, the last one kept: consecutive samples often share one."""
        if getattr(self, "_last", (None,))[0] != (id(dataset), obs_id):
            self._last = ((id(dataset), obs_id), dataset.observation(obs_id))
        return self._last[1]


def absolute_gt_only(samples):
    """The rows whose ground truth is an absolute pose (see :meth:`Protocol.score_units`)."""
    if len(samples) == 0 or "info" not in samples:
        return samples
    keep = samples["info"].map(lambda i: not (isinstance(i, dict) and i.get("absolute_gt") is False))
    return samples[keep.astype(bool)].reset_index(drop=True)


class GtModel(Protocol):
    """Each partial view registered to the observed instance's own complete model."""

    name = "gt_model"

    def sample_ids(self, dataset: ObjectDataset) -> list[str]:
        return list(dataset.observation_ids())

    def load(self, dataset: ObjectDataset, sample_id: str) -> Sample:
        obs = self._observation(dataset, sample_id)
        return make_sample(obs, dataset.instance_model(obs.category, obs.instance_id), sample_id, sample_id)


class Templates(Protocol):
    """Each view registered to each of its category's templates (``dataset.category_templates``).

    Sample ids are ``"<obs_id>|<k>"`` with ``k`` the template's index; ``group_id`` is the
    observation id. :meth:`view_templates` gives a sample's view templates, which the runner hands
    to the method side's choice (:class:`catpose.methods.template_choice.TemplateChoice`) after each
    registration; ``score_units`` keeps, per observation, the row the rule ``choice`` keeps given the
    facts the rows store (:func:`choose_row`) and adds
    ``oracle_err_deg``, the minimum error across templates, which needs ground truth and is
    labelled an oracle.

    Args:
        max_templates: use only the first K templates (None: all listed).
        exclude_templates: a template instance's own views are not test views.
        exclude_instances: instance ids whose views are not test views.
        choice: the rule that keeps a view's row: a :class:`~catpose.methods.choice_rules.ChoiceRule`
            (the builder makes it from the ``choice`` config group) or a rule name with its default
            weights.
    """

    name = "templates"

    def __init__(
        self,
        max_templates: int | None = None,
        exclude_templates: bool = False,
        exclude_instances: list[str] | None = None,
        choice: str | ChoiceRule = DEFAULT_RULE,
    ) -> None:
        self.max_templates = max_templates
        self.exclude_templates = bool(exclude_templates)  # skip views of the template instances themselves
        self.exclude_instances = [str(i) for i in (exclude_instances or [])]  # and of these instances
        self.choice = as_rule(choice)  # how a view's row is kept (catpose.methods.choice_rules)

    def _templates(self, dataset: ObjectDataset, category: str) -> list[Template]:
        templates = list(dataset.category_templates(category))
        if not templates:
            raise DatasetError(
                f"dataset {dataset.name!r} has no templates for category {category!r}; list them in the dataset config"
            )
        return templates[: self.max_templates] if self.max_templates else templates

    def sample_ids(self, dataset: ObjectDataset) -> list[str]:
        require_consistent_frames(dataset, f"protocol={self.name}")
        ids: list[str] = []
        counts: dict[str, int] = {}
        for obs_id in dataset.observation_ids():
            category = dataset.category_of(obs_id)
            n = counts.get(category)
            if n is None:
                n = counts[category] = len(self._templates(dataset, category))
            if is_excluded_view(
                obs_id, self._templates(dataset, category) if self.exclude_templates else [], self.exclude_instances
            ):
                continue
            ids.extend(template_sample_id(obs_id, k) for k in range(n))
        return ids

    def load(self, dataset: ObjectDataset, sample_id: str) -> Sample:
        require_consistent_frames(dataset, f"protocol={self.name}")
        obs_id, k = split_template_sample_id(sample_id)
        obs = self._observation(dataset, obs_id)
        template = self._templates(dataset, obs.category)[k]
        return with_template_facts(make_sample(obs, template, sample_id, obs_id))

    def view_templates(self, dataset: ObjectDataset, sample: Sample) -> tuple[list[Template], int]:
        """The K templates of ``sample``'s view, in order, and the index of its own among them."""
        return self._templates(dataset, sample.problem.category), split_template_sample_id(sample.problem.sample_id)[1]

    def score_units(self, samples):
        return self.best_per_view(absolute_gt_only(samples))

    def best_per_view(self, samples):
        """One row per view (``group_id``): the registration the rule ``choice`` keeps, with
        ``oracle_err_deg`` (the lowest error of the view's registrations) and ``oracle_trans_err``
        (that registration's translation error), ``n_templates`` and the summed ``runtime_s`` of
        the group (with the ``cross`` rule's checks)."""
        import pandas as pd

        if len(samples) == 0:
            return samples
        rows = []
        for _, g in samples.groupby("group_id", sort=False):
            row = choose_row(g, self.choice).copy()
            err = pd.to_numeric(g["err_deg"], errors="coerce").where(g["status"] == "ok")
            best = err.idxmin() if err.notna().any() else None  # the oracle's registration
            row["oracle_err_deg"] = 180.0 if best is None else float(err[best])
            trans = (
                None if best is None or "trans_err" not in g else pd.to_numeric(g["trans_err"], errors="coerce")[best]
            )
            row["oracle_trans_err"] = float("nan") if trans is None else float(trans)
            row["n_templates"] = len(g)
            row["runtime_s"] = float(pd.to_numeric(g["runtime_s"], errors="coerce").sum()) + self._choice_s(g)
            rows.append(row)
        return pd.DataFrame(rows).reset_index(drop=True)

    def _choice_s(self, group) -> float:
        """Seconds the view's choice itself took: the cross rules' checks, with the turned
        candidates' for the turn rules (0 for the other rules)."""
        if self.choice.rule not in CROSS_RULES or "info" not in group:
            return 0.0
        keys = ("cross_check_s", "turns_s") if self.choice.rule in TURN_RULES else ("cross_check_s",)
        return float(sum(i.get(k, 0.0) for i in group["info"] if isinstance(i, dict) for k in keys))


# ---------------------------------------------------------------------------------------------
# a templates run's rows: their sample ids, the views left out, and the row each view keeps


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


def choose_row(group, choice: str | ChoiceRule = DEFAULT_RULE):
    """The row (a pandas Series) one view keeps among its registrations (``group``: the view's rows
    of ``samples.jsonl`` as a DataFrame, one per template) under ``choice`` (a rule name, with its
    default weights, or a :class:`~catpose.methods.choice_rules.ChoiceRule`), applied to the facts the
    runner stored in each row's ``info`` (``cross_costs``, ``top_offset``, ``turns``). A turn or a
    fused pose replaces the row's ``T_est`` and errors (``info["turn_deg"]``, ``info["fused_templates"]``).

    Raises:
        ConfigError: the rule needs facts the rows do not store (written before them).
    """
    rule = as_rule(choice)
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
