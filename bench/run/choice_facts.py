"""The facts hook of a run whose protocol keeps one of a view's K template registrations.

After each registration of a ``templates`` run, the method side's choice
(:class:`catpose.methods.template_choice.TemplateChoice`, the ``choice`` config group) checks the
estimate on every template of its view (:meth:`~catpose.methods.template_choice.TemplateChoice.estimate_facts`:
the cross check's ICP, the top offset, the turned candidates); :func:`catpose.bench.run.sample_run.run_one`
stores what it found in the row's ``info``, and the protocol's scoring applies the rule to it. The
protocol says which templates a view has (``view_templates``); it runs no registration code.
"""

from __future__ import annotations

from typing import Any

import numpy as np


class ChoiceFacts:
    """``estimate_facts(dataset, sample, T_template_camera)``: ``chooser``'s facts about one
    finished estimate (4, 4) on the templates ``protocol`` gives its view."""

    def __init__(self, protocol: Any, chooser: Any) -> None:
        self.protocol = protocol
        self.chooser = chooser

    def estimate_facts(self, dataset: Any, sample: Any, T_template_camera: np.ndarray) -> dict:
        templates, own = self.protocol.view_templates(dataset, sample)
        return self.chooser.estimate_facts(sample.problem.points_camera, templates, own, T_template_camera)


def facts_hook(protocol: Any, chooser: Any) -> ChoiceFacts | None:
    """The hook of a run: None unless the protocol lists a view's templates (``templates``, and
    ``relative`` with category templates) and the run has a choice
    (:func:`catpose.bench.run.build.build_choice`)."""
    if chooser is None or getattr(protocol, "view_templates", None) is None:
        return None
    return ChoiceFacts(protocol, chooser)
