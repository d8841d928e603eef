"""Ours, the paper's method (Section III) with its depth-image stages: :class:`Ours`.

:meth:`Ours.register` is the list of stages, each a module of this package:

0. with a depth image, the points within the object's depth span (:mod:`~catpose.methods.ours.span`:
   a mask that bleeds onto a far background moves no statistic);
1. hypotheses from the dictionary (:mod:`~catpose.methods.ours.hypotheses`): partial templates,
   keypoints, descriptors, affinities and an SVD pose per partial;
2. solving (:mod:`~catpose.methods.ours.solver`): the two stages of pose (and soft
   correspondences) on all candidates at once (closed-form IRLS, or the paper's Adam);
3. with a depth image (``selection.rule=depth``): the resting directions
   (:mod:`~catpose.methods.ours.resting`), the coarse search over every resting pose x yaw
   (:mod:`~catpose.methods.ours.rest_search`), the depth check
   (:mod:`~catpose.methods.ours.check`) and the choice among the pool with refinement
   (:mod:`~catpose.methods.ours.choice`, :mod:`~catpose.methods.ours.refine`);
4. without one: the paper's choice among the candidates (visibility, Chamfer or loss) and
   refinement (:mod:`~catpose.methods.ours.point_choice`).

Choices where the paper is silent or that were measured: docs/choosing-defaults.md (the values in
configs/method/ours.yaml and the named constants of each stage module).

Layered calls: :meth:`Ours.candidates` returns every candidate (affinity, SVD pose, optimised
pose, loss, final correspondences); :meth:`Ours.register` chooses and refines one;
:meth:`Ours.register_batch` registers several problems with one solver launch for all of their
candidates (the GPU path).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from catpose.lru import LRUCache
from catpose.methods import options
from catpose.methods.descriptors import LPS, Descriptor
from catpose.methods.dictionary import DictionaryLayout
from catpose.methods.method import RegistrationMethod
from catpose.methods.ours import check, choice, hypotheses, point_choice, rest_search, resting, solver, span
from catpose.methods.ours.candidates import Candidates, Prepared, TemplateFeatures
from catpose.methods.ours.settings import OptimiserSettings, RestingSettings, SelectionSettings
from catpose.methods.registry import SuiteRow, register_method
from catpose.types import RegistrationProblem, RegistrationResult, Template

__all__ = ["Ours"]

#: the rule of problems without a depth image or template mesh under ``rule=depth``
#: (docs/choosing-defaults.md: ModelNet40 train shapes and the embedded set)
POINT_RULE = "visibility"


class Ours(RegistrationMethod):
    """Multi-hypothesis correspondence matching against a partial-template dictionary.

    Args:
        descriptor: keypoint descriptor (:class:`~catpose.methods.descriptors.LPS`, the paper's, or
            ``PFH``); its ``voxel_size`` downsamples input and partials so local densities match.
        dictionary: partial-template layout and keypoint count ``n`` (``2n`` per partial).
        optimiser: the solver (:class:`OptimiserSettings`).
        selection: the choice and refinement (:class:`SelectionSettings`).
        resting: the resting-pose search (:class:`RestingSettings`; ``rule=depth`` with a depth
            image only).
    """

    def __init__(
        self,
        descriptor: Descriptor | None = None,
        dictionary: DictionaryLayout | None = None,
        optimiser: OptimiserSettings | None = None,
        selection: SelectionSettings | None = None,
        resting: RestingSettings | None = None,
    ) -> None:
        for key, value, cls in (
            ("descriptor", descriptor, Descriptor),
            ("dictionary", dictionary, DictionaryLayout),
            ("optimiser", optimiser, OptimiserSettings),
            ("selection", selection, SelectionSettings),
            ("resting", resting, RestingSettings),
        ):
            options.instance_of(f"method.{key}", value, cls)
        self.descriptor = descriptor or LPS()
        self.layout = dictionary or DictionaryLayout()
        self.optimiser = optimiser or OptimiserSettings()
        self.selection = selection or SelectionSettings()
        self.resting = resting or RestingSettings()
        self.num_keypoints = self.layout.num_keypoints
        # holds the shared LPS grids (~25 MB a template)
        self._features: LRUCache[tuple, TemplateFeatures] = LRUCache(32)

    # ----------------------------------------------------------------- the stages
    def register(self, problem: RegistrationProblem) -> RegistrationResult:
        timings: dict[str, float] = {}
        if not self.uses_depth(problem):
            return self._point_choice(problem, self.candidates(problem, timings), timings)
        sel = self.selection
        problem, n_far = span.observed_points(problem)  # the points within the object's depth span
        t0 = time.perf_counter()
        ups = resting.ups(problem.template, self.resting)
        timings["hypotheses"] = time.perf_counter() - t0
        cands = self.candidates(problem, timings)  # the dictionary's, on the template's own up
        feats = self.template_features(problem.template)
        verifier = check.depth_verifier(sel, problem)  # one per problem: every stage below shares it
        searched = rest_search.search(problem, ups, cands, feats, verifier, self.resting, timings)
        pool = np.concatenate([choice.dictionary_pool(sel, problem, cands, feats, ups[0]), searched])
        ups = ups if len(searched) else ups[:1]  # without the resting-pose search, the own up only
        result = choice.select_by_depth(sel, problem, pool, cands, feats, ups, timings, verifier)
        stages = choice.stage_lists(candidates=cands.T, **({"rest_grid": searched} if len(searched) else {}), pool=pool)
        stages = {**stages, **result.extras["hypothesis_stages"]}
        extras = dict(result.extras, hypothesis_stages=stages, depth_far_points=n_far)
        return choice.poor_fit(sel, problem, replace(result, extras=extras), cands, feats, verifier, timings)

    def uses_depth(self, problem: RegistrationProblem) -> bool:
        """Whether ``problem`` is chosen by the depth check: ``rule=depth``, a depth image with a
        non-empty mask and a template mesh (otherwise the :data:`POINT_RULE` applies)."""
        image = problem.depth_image
        return (
            self.selection.rule == "depth"
            and image is not None
            and problem.template.has_mesh
            and bool(image.mask.any())
        )

    @property
    def point_selection(self) -> SelectionSettings:
        """The selection settings of problems without a depth image (``rule=depth`` falls back to
        :data:`POINT_RULE`; every other rule is its own)."""
        return replace(self.selection, rule=POINT_RULE) if self.selection.rule == "depth" else self.selection

    def _point_choice(self, problem: RegistrationProblem, c: Candidates, timings) -> RegistrationResult:
        feats = self.template_features(problem.template)
        return point_choice.finish(self.point_selection, problem, c, feats, timings)

    # ----------------------------------------------------------------- layered calls
    def template_features(self, template: Template) -> TemplateFeatures:
        """Keypoints and descriptors of every partial template, cached per template and parameters
        (:func:`catpose.methods.ours.hypotheses.template_features`)."""
        dictionary = self.layout.dictionary(template)
        key = (
            dictionary.key,
            tuple(np.round(np.asarray(template.up, dtype=np.float64), 12)),
            self.descriptor.cache_key(),
            self.num_keypoints,
        )
        return self._features.get_or_build(
            key, lambda: hypotheses.template_features(self.descriptor, self.layout, template)
        )

    def prepare_template(self, template: Template) -> None:
        """Build the per-template data now instead of on the first registration: the dictionary's
        features of the template (the disk cache's), its resting directions and the depth check's
        ray caster of its mesh."""
        self.template_features(template)
        resting.ups(template, self.resting)
        if template.has_mesh and self.selection.rule == "depth":
            check.caster_for(template)

    def prepare(self, problem: RegistrationProblem, timings: dict[str, float]) -> Prepared:
        """Everything before the solver: keypoints, affinities, SVD poses."""
        t0 = time.perf_counter()
        self.layout.dictionary(problem.template)
        timings["dictionary"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        feats = self.template_features(problem.template)
        inp = hypotheses.input_features(self.descriptor, self.num_keypoints, problem)
        timings["descriptors"] = time.perf_counter() - t0
        return hypotheses.prepare(self.descriptor, feats, inp, timings)

    def candidates(self, problem: RegistrationProblem, timings: dict[str, float] | None = None) -> Candidates:
        """Affinities, SVD poses and solved poses of every candidate (no choice)."""
        timings = {} if timings is None else timings
        x = self.prepare(problem, timings)
        t0 = time.perf_counter()
        T, losses, C = solver.optimise(self.optimiser, x.keypoints, x.P_t, x.A, x.T_svd)
        timings["optimization"] = time.perf_counter() - t0
        return Candidates(x.points, x.keypoints, x.chamfer_src, x.A, x.T_svd, T, losses, C)

    def register_batch(self, problems: Sequence[RegistrationProblem]) -> list[RegistrationResult]:
        """:meth:`register` for several problems, with one solver launch for the candidates of all
        of them (``solver=irls``: batched torch on ``optimiser.device``, float32 on cuda).

        On the CPU the answers equal :meth:`register`'s up to the last bits (the compiled kernel
        and torch differ there); the adam solver and problems with a depth image register one by
        one. Each result's ``timings["optimization"]`` is its share of the batch's solver time.
        """
        from catpose.methods.ours import irls

        opt = self.optimiser
        if opt.solver != "irls" or any(self.uses_depth(p) for p in problems):
            return [self.register(p) for p in problems]
        timings: list[dict[str, float]] = [{} for _ in problems]
        prepared = [self.prepare(p, tm) for p, tm in zip(problems, timings)]
        t0 = time.perf_counter()
        solved = irls.solve_many(
            [(x.keypoints, x.P_t, x.A, x.T_svd) for x in prepared],
            solver.IRLS_STAGES[opt.mode],
            solver.IRLS_BETA,
            opt.irls_iterations,
            solver.IRLS_TOL,
            opt.device,
            "float32" if opt.device.startswith("cuda") else "float64",
        )
        share = (time.perf_counter() - t0) / max(len(problems), 1)
        results = []
        for p, x, (T, losses, C, _), tm in zip(problems, prepared, solved, timings):
            tm["optimization"] = share
            c = Candidates(x.points, x.keypoints, x.chamfer_src, x.A, x.T_svd, T, losses, C)
            results.append(self._point_choice(p, c, tm))
        return results


register_method(
    "ours",
    "Ours",
    uses_up=True,  # descriptor frames and the gravity filter
    prepare_template=Ours.prepare_template,
    suite=(SuiteRow("ours", rank=0), SuiteRow("ours-visibility", ("method.selection.rule=visibility",), 1)),
)(Ours)
