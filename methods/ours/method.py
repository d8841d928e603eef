"""The paper's method: dictionary matching with soft correspondences (Section III).

Pipeline for one problem (input cloud ``X_c`` in the camera frame, template ``X*_t``):

1. Dictionary: ``m`` partial templates of ``X*_t`` laid out by a
   :class:`~catpose.methods.dictionary.DictionaryLayout` (default 18 views, 3 elevation rings
   0/30/60 deg x 6 azimuths, hidden point removal), cached.
2. Both the input and every partial template are voxel-downsampled with ``voxel_size`` so that
   their local point densities (which descriptors see) match.
3. Keypoints by farthest point sampling (start index 0): ``n`` on the input, ``2n`` on each
   partial (:mod:`catpose.methods.keypoints`).
4. Descriptors and affinity ``A`` (m, n, 2n) from the injected
   :class:`~catpose.methods.descriptors.Descriptor`: ``LPS`` (F-score of local patches, default) or
   ``PFH`` (1 / (marginal EMD + eps)); rows normalised to sum to 1. Template-side keypoints and
   descriptors are computed once per template and cached in memory.
5. Initial pose per partial: soft targets ``A P_t`` and Kabsch/SVD with the reflection fix.
6. Optimisation of all ``m`` candidates at once: stage 1 updates the pose only, loss
   ``sum(A . d(T P_c, P_t))``; stage 2 updates the pose and the soft correspondences ``C``, loss
   ``sum(C . d(T P_c, P_t))``. ``solver=irls`` (default) solves each stage in closed form by
   iteratively reweighted Kabsch, stage 2 with the KL trust region ``C = softmax_rows(log A -
   beta d)`` (:mod:`catpose.methods.ours.irls`, a compiled kernel on the CPU, batched torch on the
   GPU); ``solver=adam`` is the paper's Adam on 6D rotations (Zhou et al. 2019), translation and
   logits ``L`` (initialised to ``log A``, ``C = softmax_rows(L)``), with an optional
   one-directional Chamfer term (input points -> complete template) of weight ``chamfer_weight``.
7. Selection among the ``m`` candidates: ``visibility`` (default: the best ``top_k`` by the
   visibility-aware Chamfer, each with its three half turns, refined, and the best of those;
   :func:`catpose.methods.pose_scores.select_with_half_turns`), ``loss`` (the paper's rule: lowest
   final loss) or ``chamfer`` (lowest one-directional Chamfer distance of the transformed input to
   the complete template), after a gravity filter dropping candidates whose rotation maps the
   known ground normal more than ``gravity_max_deg`` away from the template's up axis.
8. Optional point-to-plane ICP refinement from the selected pose.

Steps 7 and 8 ask hundreds of nearest-neighbour questions per problem; they run as compiled
kernels on a grid of the template (:mod:`catpose.cell_grid`, exact like a KD-tree):
:mod:`catpose.point_to_plane_kernel` refines all hypotheses in one call and
:mod:`catpose.methods.pose_scores_kernel` scores all poses in one call.

``score`` is the selection criterion of the selected candidate: its final loss divided by ``n``
(the mean correspondence-weighted keypoint distance) for ``selection="loss"``, or the
one-directional Chamfer distance (mean distance of the transformed input to the nearest complete-
template point) of the returned (refined, if ``refine``) pose for ``selection="chamfer"``; both
are in object-normalised units and comparable across templates (all share the unit-sphere scale).

Choices where the paper is silent or that were measured (numbers in configs/method/ours.yaml):

- ``lr = 1e-2``, 300 + 300 steps: at the paper's 1e-3 the pose barely leaves the SVD start; fewer
  steps at a larger rate lose accuracy on ModelNet40 (own model as template).
- ``selection = chamfer`` and ``gravity_max_deg = 30``: the final WPD loss of candidates with
  different partial templates is a weak criterion across templates (the templates protocol picks
  the template by ``score``); the Chamfer distance to the complete template is not, and the
  gravity filter removes 180-degree flips the loss prefers.
- ``refine = true``: point-to-plane ICP from the selected pose costs a few ms and removes the
  keypoint-discretisation error left by the keypoint-to-keypoint loss.
- ``solver=irls``: 5 + 5 iterations replace 300 + 300 Adam steps (numbers in the config).
- The Adam optimisation uses analytic gradients (:mod:`catpose.methods.ours.adam`); per-step overhead,
  not arithmetic, dominates at (18, 32, 64), so one torch thread (the runner's ``threads``) is
  enough.

Layered calls: :meth:`Ours.candidates` returns every candidate (affinity, SVD pose, optimised
pose, loss, final correspondences); :meth:`Ours.register` selects and refines one;
:meth:`Ours.register_batch` registers several problems with one solver launch for all of their
candidates (the GPU path).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from catpose import cell_grid
from catpose.content_hash import content_hash
from catpose.errors import InvalidInputError
from catpose.kabsch import kabsch
from catpose.lru import LRUCache
from catpose.methods import options
from catpose.methods.descriptors import LPS, Descriptor
from catpose.methods.dictionary import DictionaryLayout
from catpose.methods.dictionary_features import dictionary_features
from catpose.methods.keypoints import farthest_point_indices
from catpose.methods.method import RegistrationMethod
from catpose.methods.ours.candidates import Candidates, Prepared, TemplateFeatures
from catpose.methods.ours.point_choice import criterion, finish
from catpose.methods.ours.settings import OptimiserSettings, RestingSettings, SelectionSettings
from catpose.methods.ours.solver import IRLS_STAGES, optimise
from catpose.types import RegistrationProblem, RegistrationResult, Template

__all__ = ["Ours"]


class Ours(RegistrationMethod):
    """Multi-hypothesis correspondence matching against a partial-template dictionary.

    Args:
        descriptor: keypoint descriptor (:class:`~catpose.methods.descriptors.LPS`, the paper's, or
            ``PFH``); its ``voxel_size`` downsamples input and partials so local densities match.
        dictionary: partial-template layout and keypoint count ``n`` (``2n`` per partial).
        optimiser: two-stage Adam settings (:class:`OptimiserSettings`).
        selection: selection rule, gravity filter and refinement (:class:`SelectionSettings`).
        chamfer_points: input / template points (FPS subsets) of the Chamfer distances.
        resting: gravity hypotheses beyond the template's up (:class:`RestingSettings`; ``rule=depth``
            with a depth image only).
    """

    def __init__(
        self,
        descriptor: Descriptor | None = None,
        dictionary: DictionaryLayout | None = None,
        optimiser: OptimiserSettings | None = None,
        selection: SelectionSettings | None = None,
        chamfer_points: int = 256,
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
        from dataclasses import replace

        self.descriptor = descriptor or LPS()
        self.layout = dictionary or DictionaryLayout()
        self.optimiser = optimiser or OptimiserSettings()
        self.selection = selection or SelectionSettings()
        self.resting = resting or RestingSettings()
        # the rule for problems without a depth image (rule=depth falls back to depth_fallback)
        self._point_selection = (
            replace(self.selection, rule=self.selection.depth_fallback)
            if self.selection.rule == "depth"
            else self.selection
        )
        self.chamfer_points = options.positive("method.chamfer_points", chamfer_points, integer=True)
        self.num_keypoints = self.layout.num_keypoints
        # holds the shared LPS grids (~25 MB a template); a template turned for a gravity hypothesis
        # is a template of its own, so the clutter set's 8 objects need up to 32
        self._features: LRUCache[tuple, TemplateFeatures] = LRUCache(32)
        self._grids: LRUCache[tuple, object] = LRUCache(16)  # the coarse search's ICP grids

    @property
    def point_selection(self) -> SelectionSettings:
        """The selection settings of problems without a depth image (``rule=depth`` falls back to
        its ``depth_fallback`` rule; every other rule is its own)."""
        return self._point_selection

    def template_features(self, template: Template) -> TemplateFeatures:
        """Keypoints and descriptors of every partial template, cached per template and parameters."""
        from scipy.spatial import cKDTree

        dictionary = self.layout.dictionary(template)
        up = np.asarray(template.up, dtype=np.float64)
        sel = self.selection
        key = (
            dictionary.key,
            tuple(np.round(up, 12)),
            self.descriptor.cache_key(),
            self.num_keypoints,
            self.chamfer_points,
            sel.refine_max_distance,
            sel.visibility_trunc,
        )
        hit = self._features.get(key)
        if hit is not None:
            return hit
        # a tiny partial repeats keypoints (padded) so all candidates batch together
        shared = dictionary_features(self.descriptor, self.layout, template, 2 * self.num_keypoints)
        complete = template.points[farthest_point_indices(template.points, self.chamfer_points)]
        feats = TemplateFeatures(
            shared.keypoints,
            shared.stacked,
            complete,
            cell_grid.build(template.points, sel.refine_max_distance, cell_grid.CACHED_CELLS_PER_REACH),
            cell_grid.build(template.points, sel.visibility_trunc, cell_grid.CACHED_CELLS_PER_REACH),
            cKDTree(template.points),
        )
        self._features.put(key, feats)
        return feats

    # ----------------------------------------------------------------- candidates
    def input_features(self, problem: RegistrationProblem):
        """The input's keypoints and descriptors (independent of the template)."""
        inp = self.descriptor.keypoint_features(
            problem.points_camera, problem.normals_camera, self.num_keypoints, problem.ground_normal_camera
        )
        if len(inp.indices) < 3:
            raise InvalidInputError(
                f"sample {problem.sample_id}: only {len(inp.indices)} points after voxel "
                f"downsampling at {self.descriptor.voxel_size}; lower method.descriptor.voxel_size"
            )
        return inp

    def prepare(self, problem: RegistrationProblem, timings: dict[str, float], inp=None) -> Prepared:
        """Everything before the optimiser: keypoints, affinities, SVD poses (``inp``: the input's
        features when already computed, :meth:`input_features`)."""
        t0 = time.perf_counter()
        self.layout.dictionary(problem.template)
        timings["dictionary"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        feats = self.template_features(problem.template)
        inp = self.input_features(problem) if inp is None else inp
        P_c = inp.keypoints
        timings["descriptors"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        A = self.descriptor.batched_affinity(inp.features, feats.stacked)  # (m, n, 2n)
        A = np.maximum(A, 0.0) + 1e-12
        A /= A.sum(axis=2, keepdims=True)
        timings["affinity"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        P_t = feats.keypoints  # (m, 2n, 3)
        m = len(P_t)
        T0 = kabsch(np.broadcast_to(P_c, (m,) + P_c.shape), A @ P_t)
        chamfer_src = inp.points[farthest_point_indices(inp.points, self.chamfer_points)]
        timings["initial_pose"] = time.perf_counter() - t0
        return Prepared(feats, inp.points, P_c, P_t, A, T0, chamfer_src)

    def candidates(self, problem: RegistrationProblem, timings: dict[str, float] | None = None, inp=None) -> Candidates:
        """Affinities, SVD poses and optimised poses of every candidate (no selection); ``inp``:
        the input's features when already computed (:meth:`input_features`)."""
        timings = {} if timings is None else timings
        x = self.prepare(problem, timings, inp)
        feats, P_c, P_t, A, T0, chamfer_src = x.feats, x.keypoints, x.P_t, x.A, x.T_svd, x.chamfer_src
        m = len(P_t)
        t0 = time.perf_counter()
        opt = self.optimiser
        stage2 = np.arange(m)
        if opt.mode == "joint" and 0 < opt.stage2_top_k < m:
            # stage 1 on all candidates, stage 2 only on the best top_k by the selection criterion
            T1, l1, _ = self._optimize(P_c, P_t, A, T0, chamfer_src, feats.complete_points, "pose")
            crit = self._criterion(problem, feats, chamfer_src, T1, l1, np.ones(m, bool))[3]
            stage2 = np.sort(np.argsort(crit, kind="stable")[: opt.stage2_top_k])
            T2, l2, C2 = self._optimize(
                P_c, P_t[stage2], A[stage2], T1[stage2], chamfer_src, feats.complete_points, "joint_only"
            )
            T, losses, C = T1, np.full(m, np.inf), A.copy()
            T[stage2], losses[stage2], C[stage2] = T2, l2, C2
        else:
            T, losses, C = self._optimize(P_c, P_t, A, T0, chamfer_src, feats.complete_points, opt.mode)
        timings["optimization"] = time.perf_counter() - t0
        return Candidates(x.points, P_c, chamfer_src, A, T0, T, losses, C, stage2)

    # ----------------------------------------------------------------- main
    def register(self, problem: RegistrationProblem) -> RegistrationResult:
        timings: dict[str, float] = {}
        if self.uses_depth(problem):
            return self._register_depth(problem, timings)
        return self._finish(problem, self.candidates(problem, timings), timings)

    def uses_depth(self, problem: RegistrationProblem) -> bool:
        """Whether ``problem`` is selected by the depth check: ``rule=depth``, a depth image with a
        non-empty mask and a template mesh (otherwise the ``depth_fallback`` rule applies)."""
        image = problem.depth_image
        return (
            self.selection.rule == "depth"
            and image is not None
            and problem.template.has_mesh
            and bool(image.mask.any())
        )

    def _register_depth(self, problem: RegistrationProblem, timings: dict[str, float]) -> RegistrationResult:
        """The depth check (:func:`catpose.methods.ours.choice.select_by_depth`) over a pool of the
        dictionary's candidates on the template's own up and the coarse search over every resting
        pose x yaw (:mod:`catpose.methods.ours.rest_search`, ``resting.grid_yaws`` > 0); the dictionary
        on the other resting directions too when the winner explains fewer than
        ``resting.escalate_below`` of the mask's pixels; the ``depth_poor_fit_rule`` among the own
        up's candidates when no pose does (fewer than ``selection.depth_min_inliers`` within
        ``depth_fit_tau``: a template unlike the object)."""
        from dataclasses import replace

        from catpose.methods.ours.choice import depth_verifier, dictionary_pool, select_by_depth, stage_lists
        from catpose.methods.ours.resting import hypotheses

        t0 = time.perf_counter()
        hyps = list(hypotheses(problem.template, self.resting))
        ups = np.stack([h.up for h in hyps])
        timings["hypotheses"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        inp = self.input_features(problem)
        timings["descriptors"] = time.perf_counter() - t0
        cands, feats = [], []

        def add(h) -> None:
            part: dict[str, float] = {}
            cands.append(self.candidates(replace(problem, template=h.template), part, inp))
            feats.append(self.template_features(h.template))
            for name, value in part.items():
                timings[name] = timings.get(name, 0.0) + value

        add(hyps[0])
        verifier = depth_verifier(self.selection, problem)  # one per problem: every call below shares it
        grid = self._rest_grid(problem, ups, cands[0], verifier, timings)
        pool = np.concatenate([dictionary_pool(self.selection, problem, hyps[:1], cands, feats, ups), grid])
        first = replace(self.selection, depth_yaw_turns=0)  # yaw turns: in the escalated pass only
        first_ups = ups if len(grid) else ups[:1]  # without the coarse search, the own up only
        result = select_by_depth(first, problem, pool, cands[0], feats[0], first_ups, timings, verifier=verifier)
        escalated = len(hyps) > 1 and result.extras["depth_inliers"] < self.resting.escalate_below
        if escalated:
            for h in hyps[1:]:
                add(h)
            pool = np.concatenate([dictionary_pool(self.selection, problem, hyps, cands, feats, ups), grid])
            result = select_by_depth(
                self.selection,
                problem,
                pool,
                cands[0],
                feats[0],
                ups,
                timings,
                verifier=verifier,
                yaw_turns=self.selection.depth_yaw_turns,
            )
        stages = stage_lists(
            candidates=np.concatenate([h.to_template(c.T) for h, c in zip(hyps, cands)]),
            **({"rest_grid": grid} if len(grid) else {}),
            pool=pool,
        )
        extras = dict(result.extras, escalated=bool(escalated))
        extras["hypothesis_stages"] = {**stages, **result.extras["hypothesis_stages"]}
        if result.extras["depth_inliers_loose"] < self.selection.depth_min_inliers:
            # no hypothesis explains the image: the template is unlike the object (category level);
            # the point rule chooses among the own up's candidates, scored by depth like the rest,
            # unless its answer explains the image far worse than the winner (a wrong pose)
            point = replace(self.selection, rule=self.selection.depth_poor_fit_rule)
            fallback = finish(point, problem, cands[0], feats[0], timings)
            ratio = self.selection.depth_poor_fit_max_ratio
            poses = [fallback.T_template_camera] + ([result.T_template_camera] if ratio > 0 else [])
            score, *winner = (float(x) for x in verifier.scores(np.stack(poses)))  # the winner only if compared
            if ratio <= 0 or score <= ratio * winner[0]:  # both on the pool's lattice
                extras.update(
                    {k: v for k, v in fallback.extras.items() if k != "hypothesis_stages"},
                    depth_poor_fit=True,
                    depth_score=score,
                    timings={k: float(v) for k, v in timings.items()},
                )
                return RegistrationResult(
                    T_template_camera=fallback.T_template_camera,
                    score=score,
                    extras=extras,
                    candidates_T=fallback.candidates_T,
                    candidate_scores=fallback.candidate_scores,
                )
            extras["depth_poor_fit_declined"] = True
        extras["depth_poor_fit"] = False
        return RegistrationResult(
            T_template_camera=result.T_template_camera,
            score=result.score,
            extras=extras,
            candidates_T=result.candidates_T,
            candidate_scores=result.candidate_scores,
        )

    def _rest_grid(self, problem: RegistrationProblem, ups: np.ndarray, cands: Candidates, verifier, timings):
        """The ``resting.grid_keep`` poses (template frame) of lowest depth cost of the coarse search
        over every resting direction ``ups`` x ``resting.grid_yaws`` yaws, each refined by
        ``grid_iterations`` ICP steps (:mod:`catpose.methods.ours.rest_search`); (0, 4, 4) when off."""
        from catpose.methods.ours.rest_search import grid_poses
        from catpose.point_to_plane_kernel import refine_many
        from catpose.yaw_icp_kernel import refine_yaw_many

        rs = self.resting
        if rs.grid_yaws <= 0 or rs.grid_keep <= 0:
            return np.zeros((0, 4, 4))
        t0 = time.perf_counter()
        tpl = problem.template
        T, _ = grid_poses(
            ups,
            problem.ground_normal_camera,
            problem.points_camera,
            tpl.points,
            tpl.normals,
            rs.grid_yaws,
            tpl.symmetry_axis,
            rs.grid_shift,
        )
        key = (
            tpl.template_id,
            content_hash(np.asarray(tpl.points, float)),
            rs.grid_max_distance,
            rs.grid_template_points,
        )
        hit = self._grids.get(key)
        if hit is None:  # a farthest-point subset of the template: fewer pairs to search at the long reach
            keep = farthest_point_indices(tpl.points, min(rs.grid_template_points, len(tpl.points)))
            grid = cell_grid.build(tpl.points[keep], rs.grid_max_distance, cell_grid.CACHED_CELLS_PER_REACH)
            hit = (grid, tpl.normals[keep])
            self._grids.put(key, hit)
        g = np.asarray(problem.ground_normal_camera, dtype=np.float64)
        g = g / np.linalg.norm(g)

        def icp(points: np.ndarray, T: np.ndarray, iterations: int, yaw: bool) -> np.ndarray:
            if yaw:  # about each pose's up: the ground normal in the template frame
                up = np.einsum("bij,j->bi", T[:, :3, :3], g)
                return refine_yaw_many(points, hit[0], hit[1], T, up, rs.grid_max_distance, iterations)
            return refine_many(points, hit[0], hit[1], T, rs.grid_max_distance, iterations)

        def search(T: np.ndarray, yaw: bool) -> np.ndarray:
            if rs.grid_iterations > 0 and 0 < rs.grid_beam < len(T):
                # a few steps on the head of the Chamfer subset (farthest-point order: a subset of it
                # too), the grid_beam of lowest one-directional Chamfer distance go on in full
                from catpose.methods.ours.point_choice import chamfer_distances

                src = cands.chamfer_src[: rs.grid_points]
                T = icp(src, T, rs.grid_first_iterations, yaw)
                feats = self.template_features(tpl)
                dists = chamfer_distances(feats.tree, src, T, feats.truncated)
                T = T[np.sort(np.argsort(dists, kind="stable")[: rs.grid_beam])]
                return icp(cands.chamfer_src, T, rs.grid_iterations, yaw)
            if rs.grid_iterations > 0:  # the Chamfer subset is in farthest-point order: its head is one too
                return icp(cands.chamfer_src[: rs.grid_points], T, rs.grid_iterations, yaw)
            return T

        T = np.concatenate(
            [search(T, yaw) for yaw in {"yaw": (True,), "full": (False,), "union": (True, False)}[rs.grid_icp]]
        )
        timings["rest_grid"] = timings.get("rest_grid", 0.0) + time.perf_counter() - t0
        t0 = time.perf_counter()
        if rs.grid_pixels < self.selection.depth_pixels:  # a coarser lattice for the many grid poses
            from dataclasses import replace

            from catpose.methods.ours.choice import depth_verifier

            sel = self.selection
            rays = max(sel.depth_max_rays * rs.grid_pixels // sel.depth_pixels, 1)
            verifier = depth_verifier(replace(sel, depth_pixels=rs.grid_pixels, depth_max_rays=rays), problem)
        scores = verifier.scores(T)
        timings["verification"] = timings.get("verification", 0.0) + time.perf_counter() - t0
        return T[np.argsort(scores, kind="stable")[: rs.grid_keep]]

    def register_batch(self, problems: Sequence[RegistrationProblem]) -> list[RegistrationResult]:
        """:meth:`register` for several problems, with one solver launch for the candidates of all
        of them (``solver=irls``: batched torch on ``optimiser.device``, float32 on cuda).

        On the CPU the answers equal :meth:`register`'s up to the last bits (the compiled kernel
        and torch differ there); the adam solver and ``stage2_top_k`` register one by one. Each
        result's ``timings["optimization"]`` is its share of the batch's solver time.
        """
        from catpose.methods.ours import irls

        opt = self.optimiser
        if opt.solver != "irls" or (opt.mode == "joint" and opt.stage2_top_k > 0):
            return [self.register(p) for p in problems]
        if any(self.uses_depth(p) for p in problems):  # several hypotheses each: one by one
            return [self.register(p) for p in problems]
        timings: list[dict[str, float]] = [{} for _ in problems]
        prepared = [self.prepare(p, tm) for p, tm in zip(problems, timings)]
        t0 = time.perf_counter()
        solved = irls.solve_many(
            [(x.keypoints, x.P_t, x.A, x.T_svd) for x in prepared],
            IRLS_STAGES[opt.mode],
            opt.irls_beta,
            opt.irls_iterations,
            opt.irls_tol,
            opt.device,
            "float32" if opt.device.startswith("cuda") else "float64",
        )
        share = (time.perf_counter() - t0) / max(len(problems), 1)
        results = []
        for p, x, (T, losses, C, _), tm in zip(problems, prepared, solved, timings):
            tm["optimization"] = share
            c = Candidates(x.points, x.keypoints, x.chamfer_src, x.A, x.T_svd, T, losses, C, np.arange(len(T)))
            results.append(self._finish(p, c, tm))
        return results

    def _finish(self, problem: RegistrationProblem, c: Candidates, timings: dict[str, float]) -> RegistrationResult:
        """Selection among the candidates and refinement of the selected one
        (:func:`catpose.methods.ours.point_choice.finish`; ``rule=depth`` without a depth image: its
        ``depth_fallback`` rule)."""
        return finish(self._point_selection, problem, c, self.template_features(problem.template), timings)

    def _criterion(
        self,
        problem: RegistrationProblem,
        feats: TemplateFeatures,
        chamfer_src: np.ndarray,
        T: np.ndarray,
        losses: np.ndarray,
        allowed: np.ndarray,
    ):
        """Chamfer distances, tilts (deg), kept mask and criterion (inf where not kept), all (m,)
        (:func:`catpose.methods.ours.point_choice.criterion`)."""
        return criterion(self._point_selection, problem, feats, chamfer_src, T, losses, allowed)

    def _optimize(
        self,
        P_c: np.ndarray,
        P_t: np.ndarray,
        A: np.ndarray,
        T0: np.ndarray,
        chamfer_src: np.ndarray,
        complete: np.ndarray,
        mode: str,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The solver on all candidates at once (:func:`catpose.methods.ours.solver.optimise`)."""
        return optimise(self.optimiser, P_c, P_t, A, T0, chamfer_src, complete, mode)
