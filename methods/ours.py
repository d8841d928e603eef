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
   beta d)`` (:mod:`catpose.methods.irls`, a compiled kernel on the CPU, batched torch on the
   GPU); ``solver=adam`` is the paper's Adam on 6D rotations (Zhou et al. 2019), translation and
   logits ``L`` (initialised to ``log A``, ``C = softmax_rows(L)``), with an optional
   one-directional Chamfer term (input points -> complete template) of weight ``chamfer_weight``.
7. Selection among the ``m`` candidates: ``visibility`` (default: the best ``top_k`` by the
   visibility-aware Chamfer, each with its three half turns, refined, and the best of those;
   :func:`catpose.methods.selection.select_with_half_turns`), ``loss`` (the paper's rule: lowest
   final loss) or ``chamfer`` (lowest one-directional Chamfer distance of the transformed input to
   the complete template), after a gravity filter dropping candidates whose rotation maps the
   known ground normal more than ``gravity_max_deg`` away from the template's up axis.
8. Optional point-to-plane ICP refinement from the selected pose.

Steps 7 and 8 ask hundreds of nearest-neighbour questions per problem; they run as compiled
kernels on a grid of the template (:mod:`catpose.cell_grid`, exact like a KD-tree):
:mod:`catpose.point_to_plane_kernel` refines all hypotheses in one call and
:mod:`catpose.methods.selection_kernel` scores all poses in one call.

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
- The Adam optimisation uses analytic gradients (:mod:`catpose.methods.optim`); per-step overhead,
  not arithmetic, dominates at (18, 32, 64), so one torch thread (the runner's ``threads``) is
  enough.

Layered calls: :meth:`Ours.candidates` returns every candidate (affinity, SVD pose, optimised
pose, loss, final correspondences); :meth:`Ours.register` selects and refines one;
:meth:`Ours.register_batch` registers several problems with one solver launch for all of their
candidates (the GPU path).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from catpose import cell_grid
from catpose.cell_grid import CellGrid
from catpose.errors import InvalidInputError
from catpose.kabsch import kabsch
from catpose.lru import LRUCache
from catpose.methods import options
from catpose.methods.base import RegistrationMethod
from catpose.methods.descriptors import LPS, Descriptor
from catpose.methods.dictionary import DictionaryLayout
from catpose.methods.dictionary_features import dictionary_features
from catpose.methods.keypoints import farthest_point_indices
from catpose.methods.ours_settings import OptimiserSettings, SelectionSettings
from catpose.point_to_plane_kernel import refine_many
from catpose.types import RegistrationProblem, RegistrationResult, Template

__all__ = ["Candidates", "OptimiserSettings", "Ours", "SelectionSettings"]



@dataclass(frozen=True, eq=False)
class _TemplateFeatures:
    """Constant per (template, parameters): keypoints (m, 2n, 3) and per-partial descriptors (the
    cache shared with the correspondence baselines, :mod:`catpose.methods.dictionary_features`),
    and what the selection searches."""

    keypoints: np.ndarray
    stacked: object              # the partials' descriptors, stacked for one batched affinity
    complete_points: np.ndarray  # (M', 3) FPS subset of the complete template for Chamfer terms
    pairing: CellGrid            # the full template points, searched within refine_max_distance (ICP)
    truncated: CellGrid          # the same, searched within visibility_trunc (visibility scores)
    tree: object                 # cKDTree of the same points (unbounded queries)


@dataclass(frozen=True, eq=False)
class _Prepared:
    """One problem up to the optimiser: features, downsampled input (N', 3), keypoints (n, 3),
    partial-template keypoints (m, 2n, 3), affinities (m, n, 2n), SVD poses (m, 4, 4), Chamfer
    source points."""

    feats: _TemplateFeatures
    points: np.ndarray
    keypoints: np.ndarray
    P_t: np.ndarray
    A: np.ndarray
    T_svd: np.ndarray
    chamfer_src: np.ndarray


#: the IRLS stages of each optimiser mode
_IRLS_STAGES = {"none": (), "pose": ("pose",), "joint": ("pose", "joint"), "joint_only": ("joint",)}


@dataclass(frozen=True, eq=False)
class Candidates:
    """Every candidate of one problem, one per partial template (``m`` of them).

    Attributes:
        points: (N', 3) downsampled input, camera frame; ``keypoints`` (n, 3) its FPS keypoints;
            ``chamfer_src`` (chamfer_points, 3) its FPS subset for the Chamfer distances.
        A: (m, n, 2n) row-normalised affinities (input keypoint -> partial-template keypoint).
        T_svd: (m, 4, 4) initial poses ``T_template_camera`` (weighted Kabsch on ``A P_t``).
        T: (m, 4, 4) poses after the optimiser (``mode=none``: ``T_svd`` rounded through the
            optimiser's float32 6D parameters and re-orthonormalised).
        losses: (m,) final mean correspondence-weighted keypoint distances (inf: not optimised
            in stage 2 with ``stage2_top_k``).
        C: (m, n, 2n) final soft correspondences (``A`` unless stage 2 ran on that candidate).
        stage2: indices of the candidates stage 2 ran on (all for the paper's setting).
    """

    points: np.ndarray
    keypoints: np.ndarray
    chamfer_src: np.ndarray
    A: np.ndarray
    T_svd: np.ndarray
    T: np.ndarray
    losses: np.ndarray
    C: np.ndarray
    stage2: np.ndarray


class Ours(RegistrationMethod):
    """Multi-hypothesis correspondence matching against a partial-template dictionary.

    Args:
        descriptor: keypoint descriptor (:class:`~catpose.methods.descriptors.LPS`, the paper's, or
            ``PFH``); its ``voxel_size`` downsamples input and partials so local densities match.
        dictionary: partial-template layout and keypoint count ``n`` (``2n`` per partial).
        optimiser: two-stage Adam settings (:class:`OptimiserSettings`).
        selection: selection rule, gravity filter and refinement (:class:`SelectionSettings`).
        chamfer_points: input / template points (FPS subsets) of the Chamfer distances.
    """

    def __init__(self, descriptor: Descriptor | None = None, dictionary: DictionaryLayout | None = None,
                 optimiser: OptimiserSettings | None = None, selection: SelectionSettings | None = None,
                 chamfer_points: int = 256) -> None:
        for key, value, cls in (("descriptor", descriptor, Descriptor), ("dictionary", dictionary, DictionaryLayout),
                                ("optimiser", optimiser, OptimiserSettings),
                                ("selection", selection, SelectionSettings)):
            options.instance_of(f"method.{key}", value, cls)
        self.descriptor = descriptor or LPS()
        self.layout = dictionary or DictionaryLayout()
        self.optimiser = optimiser or OptimiserSettings()
        self.selection = selection or SelectionSettings()
        self.chamfer_points = options.positive("method.chamfer_points", chamfer_points, integer=True)
        self.num_keypoints = self.layout.num_keypoints
        self._features: LRUCache[tuple, _TemplateFeatures] = LRUCache(8)  # holds the shared LPS grids (~25 MB a template)

    def template_features(self, template: Template) -> _TemplateFeatures:
        """Keypoints and descriptors of every partial template, cached per template and parameters."""
        from scipy.spatial import cKDTree

        dictionary = self.layout.dictionary(template)
        up = np.asarray(template.up, dtype=np.float64)
        sel = self.selection
        key = (dictionary.key, tuple(np.round(up, 12)), self.descriptor.cache_key(), self.num_keypoints,
               self.chamfer_points, sel.refine_max_distance, sel.visibility_trunc)
        hit = self._features.get(key)
        if hit is not None:
            return hit
        # a tiny partial repeats keypoints (padded) so all candidates batch together
        shared = dictionary_features(self.descriptor, self.layout, template, 2 * self.num_keypoints)
        complete = template.points[farthest_point_indices(template.points, self.chamfer_points)]
        feats = _TemplateFeatures(shared.keypoints, shared.stacked, complete,
                                  cell_grid.build(template.points, sel.refine_max_distance),
                                  cell_grid.build(template.points, sel.visibility_trunc), cKDTree(template.points))
        self._features.put(key, feats)
        return feats

    # ----------------------------------------------------------------- candidates
    def _prepare(self, problem: RegistrationProblem, timings: dict[str, float]) -> _Prepared:
        """Everything before the optimiser: keypoints, affinities, SVD poses."""
        t0 = time.perf_counter()
        self.layout.dictionary(problem.template)
        timings["dictionary"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        feats = self.template_features(problem.template)
        inp = self.descriptor.keypoint_features(problem.points_camera, problem.normals_camera, self.num_keypoints,
                                                problem.ground_normal_camera)
        if len(inp.indices) < 3:
            raise InvalidInputError(f"sample {problem.sample_id}: only {len(inp.indices)} points after voxel "
                                    f"downsampling at {self.descriptor.voxel_size}; lower method.descriptor.voxel_size")
        P_c = inp.keypoints
        timings["descriptors"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        A = self.descriptor.batched_affinity(inp.features, feats.stacked)        # (m, n, 2n)
        A = np.maximum(A, 0.0) + 1e-12
        A /= A.sum(axis=2, keepdims=True)
        timings["affinity"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        P_t = feats.keypoints                                                     # (m, 2n, 3)
        m = len(P_t)
        T0 = kabsch(np.broadcast_to(P_c, (m,) + P_c.shape), A @ P_t)
        chamfer_src = inp.points[farthest_point_indices(inp.points, self.chamfer_points)]
        timings["initial_pose"] = time.perf_counter() - t0
        return _Prepared(feats, inp.points, P_c, P_t, A, T0, chamfer_src)

    def candidates(self, problem: RegistrationProblem, timings: dict[str, float] | None = None) -> Candidates:
        """Affinities, SVD poses and optimised poses of every candidate (no selection)."""
        timings = {} if timings is None else timings
        x = self._prepare(problem, timings)
        feats, P_c, P_t, A, T0, chamfer_src = x.feats, x.keypoints, x.P_t, x.A, x.T_svd, x.chamfer_src
        m = len(P_t)
        t0 = time.perf_counter()
        opt = self.optimiser
        stage2 = np.arange(m)
        if opt.mode == "joint" and 0 < opt.stage2_top_k < m:
            # stage 1 on all candidates, stage 2 only on the best top_k by the selection criterion
            T1, l1, _ = self._optimize(P_c, P_t, A, T0, chamfer_src, feats.complete_points, "pose")
            crit = self._criterion(problem, feats, chamfer_src, T1, l1, np.ones(m, bool))[3]
            stage2 = np.sort(np.argsort(crit, kind="stable")[:opt.stage2_top_k])
            T2, l2, C2 = self._optimize(P_c, P_t[stage2], A[stage2], T1[stage2], chamfer_src,
                                        feats.complete_points, "joint_only")
            T, losses, C = T1, np.full(m, np.inf), A.copy()
            T[stage2], losses[stage2], C[stage2] = T2, l2, C2
        else:
            T, losses, C = self._optimize(P_c, P_t, A, T0, chamfer_src, feats.complete_points, opt.mode)
        timings["optimization"] = time.perf_counter() - t0
        return Candidates(x.points, P_c, chamfer_src, A, T0, T, losses, C, stage2)

    def _criterion(self, problem: RegistrationProblem, feats: _TemplateFeatures, chamfer_src: np.ndarray,
                   T: np.ndarray, losses: np.ndarray, allowed: np.ndarray):
        """Chamfer distances, tilts (deg), kept mask and criterion (inf where not kept), all (m,)."""
        dists = _chamfer(feats.tree, chamfer_src, T)
        up = np.asarray(problem.template.up, dtype=np.float64) / np.linalg.norm(problem.template.up)
        g_template = np.einsum("mij,j->mi", T[:, :3, :3], problem.ground_normal_camera)
        tilt = np.degrees(np.arccos(np.clip(g_template @ up, -1.0, 1.0)))
        keep = allowed.copy()
        if self.selection.gravity_max_deg is not None:
            keep &= tilt <= self.selection.gravity_max_deg
            if not keep.any():  # nothing is consistent with gravity: fall back to all allowed
                keep = allowed.copy()
        crit = losses if self.selection.rule == "loss" else dists
        return dists, tilt, keep, np.where(keep, crit, np.inf)

    # ----------------------------------------------------------------- main
    def register(self, problem: RegistrationProblem) -> RegistrationResult:
        timings: dict[str, float] = {}
        return self._finish(problem, self.candidates(problem, timings), timings)

    def register_batch(self, problems: Sequence[RegistrationProblem]) -> list[RegistrationResult]:
        """:meth:`register` for several problems, with one solver launch for the candidates of all
        of them (``solver=irls``: batched torch on ``optimiser.device``, float32 on cuda).

        On the CPU the answers equal :meth:`register`'s up to the last bits (the compiled kernel
        and torch differ there); the adam solver and ``stage2_top_k`` register one by one. Each
        result's ``timings["optimization"]`` is its share of the batch's solver time.
        """
        from catpose.methods import irls

        opt = self.optimiser
        if opt.solver != "irls" or (opt.mode == "joint" and opt.stage2_top_k > 0):
            return [self.register(p) for p in problems]
        timings: list[dict[str, float]] = [{} for _ in problems]
        prepared = [self._prepare(p, tm) for p, tm in zip(problems, timings)]
        t0 = time.perf_counter()
        solved = irls.solve_many([(x.keypoints, x.P_t, x.A, x.T_svd) for x in prepared], _IRLS_STAGES[opt.mode],
                                 opt.irls_beta, opt.irls_iterations, opt.irls_tol, opt.device,
                                 "float32" if opt.device.startswith("cuda") else "float64")
        share = (time.perf_counter() - t0) / max(len(problems), 1)
        results = []
        for p, x, (T, losses, C, _), tm in zip(problems, prepared, solved, timings):
            tm["optimization"] = share
            c = Candidates(x.points, x.keypoints, x.chamfer_src, x.A, x.T_svd, T, losses, C, np.arange(len(T)))
            results.append(self._finish(p, c, tm))
        return results

    def _finish(self, problem: RegistrationProblem, c: Candidates, timings: dict[str, float]) -> RegistrationResult:
        """Selection among the candidates and refinement of the selected one."""
        feats = self.template_features(problem.template)
        chamfer_src = c.chamfer_src

        t0 = time.perf_counter()
        allowed = np.zeros(len(c.T), dtype=bool)
        allowed[c.stage2] = True
        dists, tilt_deg, keep, crit = self._criterion(problem, feats, chamfer_src, c.T, c.losses, allowed)
        best = int(np.argmin(crit))
        score = float(crit[best])
        T_best = c.T[best]
        timings["selection"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        sel = self.selection
        half_turn = None
        template = problem.template
        candidate_scores = crit

        def refine(T: np.ndarray, points: np.ndarray = chamfer_src) -> np.ndarray:
            """Poses (B, 4, 4) refined by point-to-plane ICP on ``points`` (all at once, compiled)."""
            if not sel.refine:
                return T
            return refine_many(points, feats.pairing, template.normals, T, sel.refine_max_distance,
                               sel.refine_iterations)

        if sel.rule == "visibility":
            from catpose.methods.selection import select_with_half_turns
            from catpose.methods.selection_kernel import visibility_scores

            input_grid = cell_grid.build(chamfer_src, sel.visibility_trunc)

            def score_of(T: np.ndarray) -> np.ndarray:
                return visibility_scores(chamfer_src, input_grid, T, feats.truncated, template.normals,
                                         sel.visibility_trunc)

            # scored and refined on the FPS subset of the Chamfer distances (4x fewer points: the
            # 4 top_k alternatives cost about what one full refinement did), the winner on all points
            T_best, score, info = select_with_half_turns(
                c.T, keep, score_of, refine, problem.ground_normal_camera, np.asarray(template.up, float),
                sel.gravity_max_deg, sel.top_k, sel.refine_top)
            T_best = refine(T_best[None], c.points)[0]
            best, half_turn = info["candidate"], info["half_turn"]
            candidate_scores = np.asarray(info["scores"], dtype=float)
        elif sel.refine:
            T_best = refine(T_best[None], c.points)[0]
            if sel.rule == "chamfer":  # the score of the pose actually returned
                score = float(_chamfer(feats.tree, chamfer_src, T_best[None])[0])
        timings["refinement"] = time.perf_counter() - t0

        extras = {"template_index": best, "losses": [float(x) if np.isfinite(x) else None for x in c.losses],
                  "chamfer": [float(x) for x in dists], "tilt_deg": [float(x) for x in tilt_deg],
                  "kept": [bool(x) for x in keep], "timings": {k: float(v) for k, v in timings.items()},
                  "num_input_points": int(len(c.points))}
        extras["stage2_candidates"] = [int(i) for i in c.stage2]
        if half_turn is not None:
            extras["half_turn"] = half_turn  # 0: the candidate itself; 1, 2, 3: turned about x, y, z
        return RegistrationResult(T_target_source=T_best, score=score, extras=extras, candidates_T=c.T.copy(),
                                  candidate_scores=np.asarray(candidate_scores, dtype=float).copy())

    # ----------------------------------------------------------------- optimisation
    def _optimize(self, P_c: np.ndarray, P_t: np.ndarray, A: np.ndarray, T0: np.ndarray, chamfer_src: np.ndarray,
                  complete: np.ndarray, mode: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The solver on all candidates at once (``mode``: none, pose, joint or joint_only). Returns
        poses (m, 4, 4), final losses (m,) as mean correspondence-weighted keypoint distances
        (object-normalised units) and the final soft correspondences C (m, n, 2n)."""
        opt = self.optimiser
        if opt.solver == "irls":
            from catpose.methods import irls

            cuda = opt.device.startswith("cuda")
            T, losses, C, _ = irls.solve_numpy(P_c, P_t, A, T0, _IRLS_STAGES[mode], opt.irls_beta,
                                               opt.irls_iterations, opt.irls_tol, opt.device,
                                               "float32" if cuda else "float64")
            return T, losses, C
        import torch

        from catpose.methods.optim import BatchedProblem, _rot6d, optimize

        dev = torch.device(self.optimiser.device)
        dt = torch.float32

        def tens(a):
            return torch.as_tensor(np.ascontiguousarray(a), dtype=dt, device=dev)

        w = self.optimiser.chamfer_weight
        prob = BatchedProblem(tens(P_c), tens(P_t), tens(A), tens(chamfer_src) if w > 0 else None,
                              tens(complete) if w > 0 else None, w)
        n = len(P_c)
        r6 = tens(np.concatenate([T0[:, :3, 0], T0[:, :3, 1]], axis=1))
        t = tens(T0[:, :3, 3])
        stages = []
        if mode in ("pose", "joint"):
            stages.append(("pose", self.optimiser.steps_pose))
        if mode in ("joint", "joint_only"):
            stages.append(("joint", self.optimiser.steps_joint))
        final, logits = optimize(prob, r6, t, stages, self.optimiser.lr)
        with torch.no_grad():
            R = _rot6d(r6)[0].cpu().double().numpy()
            tt = t.cpu().double().numpy()
            C = A if logits is None else torch.softmax(logits, dim=2).cpu().double().numpy()
        # re-orthonormalise in float64 so validate_pose accepts the result
        U, _, Vt = np.linalg.svd(R)
        R = U @ Vt
        T = np.tile(np.eye(4), (len(R), 1, 1))
        T[:, :3, :3], T[:, :3, 3] = R, tt
        return T, final.detach().cpu().double().numpy() / n, C


def _chamfer(tree, points: np.ndarray, T: np.ndarray) -> np.ndarray:
    """One-directional Chamfer distance (mean nearest-template-point distance) of ``points``
    (N, 3) under each pose of ``T`` (B, 4, 4); (B,), object-normalised units. One KD-tree query
    for all poses (unbounded distances: a KD-tree, not the grid, is the right structure)."""
    moved = np.einsum("bij,nj->bni", T[:, :3, :3], points) + T[:, None, :3, 3]
    return tree.query(moved.reshape(-1, 3))[0].reshape(len(T), len(points)).mean(axis=1)
