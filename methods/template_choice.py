"""Choosing among K templates (the ``choice`` config group): :class:`TemplateChoice` computes an
estimate's facts after its registration (:meth:`~TemplateChoice.estimate_facts`, by
:class:`~catpose.methods.cross_check.CrossCheck`) and keeps one of K estimates by its rule
(:func:`catpose.methods.choice_rules.choose`). The benchmark's templates protocol stores the facts
in each row and applies the same ``choose`` to them, so it reports what this component returns.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.errors import ConfigError, InvalidInputError, one_line
from catpose.methods import options
from catpose.methods.choice_rules import (
    AGREE_DEG,
    CROSS_WEIGHT,
    DEFAULT_RULE,
    DENSITY_WEIGHT,
    FUSED_TOP_WEIGHT,
    TOP_WEIGHT,
    TURN_RULES,
    Choice,
    ChoiceRule,
    TemplateEstimate,
    choose,
    template_spacing,
)
from catpose.methods.cross_check import TURNS_DEG, CrossCheck


def turns_of(turns_deg: Any) -> tuple[float, ...]:
    """``turns_deg`` as a tuple of degrees (``[]``: none).

    Raises:
        ConfigError: a turn that is not a number, or not a list.
    """
    try:
        if turns_deg is None or isinstance(turns_deg, str):
            raise TypeError(turns_deg)
        return tuple(float(t) for t in turns_deg)
    except (TypeError, ValueError):
        raise ConfigError(
            f"choice.turns_deg={turns_deg!r} must be a list of degrees, e.g. [90, 270], or [] for none"
        ) from None


class TemplateChoice:
    """Keeps one of a view's K template registrations (module doc).

    Args:
        rule: the rule (:data:`catpose.methods.choice_rules.RULES`; default
            :data:`~catpose.methods.choice_rules.DEFAULT_RULE`, ``fused``).
        cross_weight, top_weight, fused_top_weight, agree_deg, density_weight: the rule's weights
            (:class:`~catpose.methods.choice_rules.ChoiceRule`).
        turns_deg: the turns about the template's up (degrees) tried from each estimate when K > 1
            (``[]``: none, faster; the turn rules then cannot choose).
        one_template_turns: with K = 1 too, under a turn rule, the facts (and so the turns) are
            computed and the rule keeps the estimate or one of its turns on the one template.
        cross_check: the cross check's settings (:class:`~catpose.methods.cross_check.CrossCheck`;
            None: its defaults).
    """

    def __init__(
        self,
        rule: str = DEFAULT_RULE,
        cross_weight: float = CROSS_WEIGHT,
        top_weight: float = TOP_WEIGHT,
        fused_top_weight: float = FUSED_TOP_WEIGHT,
        agree_deg: float = AGREE_DEG,
        density_weight: float = DENSITY_WEIGHT,
        turns_deg: Sequence[float] = TURNS_DEG,
        one_template_turns: bool = False,
        cross_check: CrossCheck | None = None,
    ) -> None:
        self.rule = ChoiceRule(
            rule=rule,
            cross_weight=float(cross_weight),
            top_weight=float(top_weight),
            fused_top_weight=float(fused_top_weight),
            agree_deg=float(agree_deg),
            density_weight=float(density_weight),
        )
        options.instance_of("choice.cross_check", cross_check, CrossCheck)
        self.cross_check = cross_check or CrossCheck()
        self.turns_deg = turns_of(turns_deg)
        self.one_template_turns = bool(one_template_turns) and rule in TURN_RULES

    def estimate_facts(
        self, points_camera: np.ndarray, templates: Sequence[Any], own: int, T_template_camera: np.ndarray
    ) -> dict:
        """What the rules read of one finished estimate ``T_template_camera`` (4, 4, camera ->
        ``templates[own]``) of the view ``points_camera`` (N, 3, camera frame): ``cross_costs``, its
        cost on each of the K ``templates`` (:meth:`CrossCheck.cross_costs`), ``top_offset``
        (:meth:`CrossCheck.top_offset`) and ``cross_check_s``, the seconds they took; ``turns``, its
        turned candidates (:meth:`CrossCheck.turn_candidates`, unless ``turns_deg`` is empty), and
        ``turns_s``, their seconds. With K = 1 nothing (there is nothing to choose), unless
        ``one_template_turns`` is set under a turn rule."""
        if len(templates) < 2 and not self.one_template_turns:
            return {}
        check = self.cross_check
        t0 = time.perf_counter()
        costs = check.cross_costs(points_camera, T_template_camera, templates, own)
        top = check.top_offset(points_camera, T_template_camera, templates, own)
        facts = {"cross_costs": costs, "top_offset": top, "cross_check_s": time.perf_counter() - t0}
        if self.turns_deg:
            t0 = time.perf_counter()
            facts["turns"] = check.turn_candidates(points_camera, T_template_camera, templates, own, self.turns_deg)
            facts["turns_s"] = time.perf_counter() - t0
        return facts

    def choose_among(self, points_camera: np.ndarray, templates: Sequence[Any], estimates: Sequence[Any]) -> Choice:
        """The pose kept among K estimates of the view ``points_camera`` (N, 3, camera frame), one
        per template of ``templates`` (in order): each a :class:`~catpose.types.RegistrationResult`,
        a (4, 4) ``T_template_camera``, or None (that registration failed). Each estimate's facts
        are computed here (:meth:`estimate_facts`, and the template's point spacing); an error
        there is kept in its facts (``estimate_facts_error``) and the estimate is chosen by what
        remains, as in a benchmark run.

        Raises:
            InvalidInputError: not one estimate per template.
        """
        if len(estimates) != len(templates) or not templates:
            raise InvalidInputError(
                f"{len(estimates)} estimates for {len(templates)} templates; pass one estimate (or None) per template"
            )
        out = []
        for k, (template, estimate) in enumerate(zip(templates, estimates)):
            T, score = _pose_and_score(estimate)
            facts: dict[str, Any] = {"template_spacing": template_spacing(template)}
            if T is not None:
                try:
                    facts.update(self.estimate_facts(points_camera, templates, k, T))
                except (ImportError, MemoryError):
                    raise
                except Exception as e:  # noqa: BLE001 - the estimate stays, chosen without its facts
                    facts["estimate_facts_error"] = one_line(e)
            out.append(TemplateEstimate(k, T, score, facts, ok=T is not None))
        return choose(out, self.rule)


def _pose_and_score(estimate: Any) -> tuple[np.ndarray | None, float]:
    """((4, 4) pose or None, score) of a :class:`~catpose.types.RegistrationResult`, a pose or None."""
    if estimate is None:
        return None, float("nan")
    T = getattr(estimate, "T_template_camera", estimate)
    return np.asarray(T, float).reshape(4, 4), float(getattr(estimate, "score", float("nan")))


def register_with_templates(
    method: Any, problem: Any, templates: Sequence[Any], chooser: TemplateChoice | None = None
) -> tuple[Choice, list[Any]]:
    """Register the view of ``problem`` (a :class:`~catpose.types.RegistrationProblem`; its own
    template is not used) on each of ``templates`` with ``method`` (``register(problem)``), then
    keep one pose with ``chooser`` (default: :class:`TemplateChoice` with its defaults, the
    ``fused`` rule, as ``bench run``). Returns the :class:`~catpose.methods.choice_rules.Choice` and the K
    :class:`~catpose.types.RegistrationResult` s (None where the method refused that template with
    a :class:`~catpose.errors.CatposeError`).

    Raises:
        CatposeError: the method refused every template (the first template's error).
    """
    from catpose.errors import CatposeError

    chooser = TemplateChoice() if chooser is None else chooser
    results: list[Any] = []
    errors: list[CatposeError] = []
    for k, template in enumerate(templates):
        try:
            results.append(
                method.register(dataclasses.replace(problem, template=template, sample_id=f"{problem.sample_id}|{k}"))
            )
        except CatposeError as e:
            results.append(None)
            errors.append(e)
    if templates and len(errors) == len(templates):
        raise errors[0]
    return chooser.choose_among(problem.points_camera, templates, results), results
