"""The paper's method: dictionary matching with soft correspondences (Section III).

Pipeline for one problem (input cloud ``X_c`` in the camera frame, template ``X*_t``):

1. Dictionary: ``m`` partial templates of ``X*_t`` (see :mod:`catpose.methods.dictionary`;
   default 18 views, 3 elevation rings 0/30/60 deg x 6 azimuths, hidden point removal), cached.
2. Both the input and every partial template are voxel-downsampled with ``voxel_size`` so that
   their local point densities (which descriptors see) match.
3. Keypoints by farthest point sampling (start index 0): ``n`` on the input, ``2n`` on each
   partial (:mod:`catpose.methods.keypoints`).
4. Descriptors and affinity ``A`` (m, n, 2n): ``lps`` (F-score of local patches, default, see
   :mod:`catpose.methods.lps`) or ``pfh`` (1 / (marginal EMD + eps), :mod:`catpose.methods.pfh`);
   rows normalised to sum to 1. Template-side keypoints and descriptors are computed once per
   template and cached in memory.
5. Initial pose per partial: soft targets ``A P_t`` and Kabsch/SVD with the reflection fix.
6. Optimisation (Adam, all ``m`` candidates as one batched tensor program of shape (m, n, 2n)):
   stage 1 updates the pose only, loss ``sum(A . d(T P_c, P_t))``; stage 2 updates the pose and
   ``C = softmax_rows(L)`` with logits ``L`` initialised to ``log A``, loss
   ``sum(C . d(T P_c, P_t))``. Rotations use the 6D representation (Zhou et al. 2019). An optional
   one-directional Chamfer term (input points -> complete template) is added with weight
   ``chamfer_weight``.
7. Selection among the ``m`` candidates: ``loss`` (the paper's rule: lowest final loss) or
   ``chamfer`` (lowest one-directional Chamfer distance of the transformed input to the complete
   template), optionally after a gravity filter dropping candidates whose rotation maps the known
   ground normal more than ``gravity_max_deg`` away from the template's up axis.
8. Optional point-to-plane ICP refinement from the selected pose.

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
- ``refine = true``: point-to-plane ICP from the selected pose costs ~10 ms and removes the
  keypoint-discretisation error left by the keypoint-to-keypoint loss.
- The optimisation uses analytic gradients (:mod:`catpose.methods.optim`) and one torch thread:
  per-step overhead, not arithmetic, dominates at (18, 32, 64).
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from catpose.errors import ConfigError
from catpose.geometry import make_T
from catpose.methods.base import RegistrationMethod
from catpose.methods.dictionary import PartialDictionary, get_dictionary
from catpose.methods.keypoints import farthest_point_indices
from catpose.types import RegistrationProblem, RegistrationResult, Template


def voxel_downsample(points: np.ndarray, normals: np.ndarray, voxel_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Keep one point per voxel (the first in input order; deterministic); normals follow."""
    if voxel_size <= 0:
        return points, normals
    keys = np.floor(points / voxel_size).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    first.sort()
    return points[first], normals[first]


def kabsch(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Batched least-squares rigid transforms (B, 4, 4) mapping P (B, n, 3) onto Q (B, n, 3),
    with the reflection fix (Sorkine 2017): ``R = V diag(1, 1, sign det(V U^T)) U^T``."""
    mp, mq = P.mean(1, keepdims=True), Q.mean(1, keepdims=True)
    H = np.einsum("bni,bnj->bij", P - mp, Q - mq)
    U, _, Vt = np.linalg.svd(H)
    V = np.swapaxes(Vt, 1, 2)
    s = np.sign(np.linalg.det(V @ np.swapaxes(U, 1, 2)))
    s[s == 0] = 1.0
    D = np.zeros_like(H)
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = s
    R = V @ D @ np.swapaxes(U, 1, 2)
    t = mq[:, 0] - np.einsum("bij,bj->bi", R, mp[:, 0])
    T = np.tile(np.eye(4), (len(P), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, t
    return T


@dataclass(frozen=True, eq=False)
class _TemplateFeatures:
    """Constant per (template, parameters): keypoints (m, 2n, 3) and per-partial descriptors."""

    keypoints: np.ndarray
    descriptors: list          # lps: VoxelPatches or Patches per partial; pfh: (2n, 125) arrays
    complete_points: np.ndarray  # (M', 3) downsampled complete template for Chamfer terms
    tree: object               # cKDTree of the full template points
    stacked: object = None     # descriptors of all partials stacked for one batched affinity


class Ours(RegistrationMethod):
    """Multi-hypothesis correspondence matching against a partial-template dictionary.

    Args:
        descriptor: ``lps`` (default; the paper's descriptor) or ``pfh``.
        num_keypoints: ``n`` input keypoints (``2n`` per partial template).
        voxel_size: downsampling voxel for input and partials, object-normalised units (0: none).
        num_views, layout, elevations_deg, view_distance, hpr_radius_factor: dictionary layout.
        lps_radius, lps_tau, lps_max_points, lps_parallel_deg, lps_fscore, lps_voxel_subdiv:
            LPS crop radius, F-score threshold (object-normalised units), patch size cap, PCA
            fallback angle (deg), ``voxel`` (fast) or ``exact`` F-score, grid cells per tau.
        pfh_radius, pfh_max_nn, pfh_eps, pfh_distance: PFH neighbourhood radius and cap,
            affinity epsilon, ``marginal`` (fast) or ``exact`` EMD.
        optimize: ``joint`` (stage 1 then stage 2, default), ``pose`` (stage 1 only) or ``none``
            (SVD initial pose only).
        steps_pose, steps_joint: Adam steps of stage 1 and stage 2 (paper: 300 each).
        lr: Adam learning rate for both stages (paper: 1e-3; default 1e-2, see config).
        stage2_top_k: if in (0, m), stage 2 runs only on the ``k`` best candidates after stage 1
            (by the selection criterion); 0 runs it on all ``m`` (the paper).
        chamfer_weight: weight of the one-directional Chamfer term (0: off).
        chamfer_points: input / template points used by Chamfer terms (FPS subsets).
        selection: ``loss`` or ``chamfer``.
        gravity_max_deg: gravity filter threshold in degrees (``None`` or <= 0: off).
        refine: run point-to-plane ICP from the selected pose.
        refine_max_distance, refine_iterations: ICP inlier distance and iterations.
        device: torch device (``cpu`` or ``cuda``).
        num_threads: torch CPU threads (0: leave torch's setting).
        seed: seed of the method's own randomness (none is used at present; kept for the API).
    """

    def __init__(self, descriptor: str = "lps", num_keypoints: int = 32, voxel_size: float = 0.025,
                 num_views: int = 18, layout: str = "rings", elevations_deg: tuple[float, ...] | list[float] = (0.0, 30.0, 60.0),
                 view_distance: float = 3.0, hpr_radius_factor: float = 100.0,
                 lps_radius: float = 0.2, lps_tau: float = 0.03, lps_max_points: int = 96,
                 lps_parallel_deg: float = 10.0, lps_fscore: str = "voxel", lps_voxel_subdiv: int = 1,
                 pfh_radius: float = 0.2, pfh_max_nn: int = 32, pfh_eps: float = 0.01, pfh_distance: str = "marginal",
                 optimize: str = "joint", steps_pose: int = 300, steps_joint: int = 300, lr: float = 1e-2,
                 stage2_top_k: int = 0,
                 chamfer_weight: float = 0.0, chamfer_points: int = 256,
                 selection: str = "chamfer", gravity_max_deg: float | None = 30.0,
                 refine: bool = True, refine_max_distance: float = 0.05, refine_iterations: int = 30,
                 device: str = "cpu", num_threads: int = 1, seed: int = 0) -> None:
        checks = {"descriptor": (descriptor, ("lps", "pfh")), "optimize": (optimize, ("joint", "pose", "none")),
                  "selection": (selection, ("loss", "chamfer")), "lps_fscore": (lps_fscore, ("voxel", "exact")),
                  "pfh_distance": (pfh_distance, ("marginal", "exact"))}
        for name, (value, allowed) in checks.items():
            if value not in allowed:
                raise ConfigError(f"method ours: {name}={value!r} is unknown; use one of {list(allowed)}")
        if num_keypoints < 3:
            raise ConfigError(f"method ours: num_keypoints={num_keypoints}; use at least 3 (e.g. 32)")
        positive = {"lps_radius": lps_radius, "lps_tau": lps_tau, "lps_voxel_subdiv": lps_voxel_subdiv,
                    "lps_max_points": lps_max_points, "pfh_radius": pfh_radius, "pfh_max_nn": pfh_max_nn,
                    "pfh_eps": pfh_eps, "lr": lr, "view_distance": view_distance,
                    "hpr_radius_factor": hpr_radius_factor, "refine_max_distance": refine_max_distance}
        for name, value in positive.items():
            if not value > 0:
                raise ConfigError(f"method ours: {name}={value}; it must be positive")
        non_negative = {"voxel_size": voxel_size, "steps_pose": steps_pose, "steps_joint": steps_joint,
                        "chamfer_weight": chamfer_weight, "refine_iterations": refine_iterations,
                        "num_threads": num_threads}
        for name, value in non_negative.items():
            if value < 0:
                raise ConfigError(f"method ours: {name}={value}; it must be >= 0")
        if str(device).startswith("cuda"):
            import torch

            if not torch.cuda.is_available():
                raise ConfigError(f"method ours: device={device!r} but torch has no CUDA device here; use device=cpu")
        from catpose.methods.dictionary import viewpoint_layout

        viewpoint_layout(int(num_views), layout, tuple(float(e) for e in elevations_deg), float(view_distance))
        self.descriptor, self.num_keypoints, self.voxel_size = descriptor, int(num_keypoints), float(voxel_size)
        self.dict_args = dict(num_views=int(num_views), layout=layout,
                              elevations_deg=tuple(float(e) for e in elevations_deg),
                              distance=float(view_distance), hpr_radius_factor=float(hpr_radius_factor))
        self.lps_radius, self.lps_tau, self.lps_max_points = float(lps_radius), float(lps_tau), int(lps_max_points)
        self.lps_parallel_deg, self.lps_fscore, self.lps_voxel_subdiv = float(lps_parallel_deg), lps_fscore, int(lps_voxel_subdiv)
        self.pfh_radius, self.pfh_max_nn, self.pfh_eps, self.pfh_distance = float(pfh_radius), int(pfh_max_nn), float(pfh_eps), pfh_distance
        self.optimize, self.steps_pose, self.steps_joint, self.lr = optimize, int(steps_pose), int(steps_joint), float(lr)
        self.stage2_top_k = int(stage2_top_k)
        self.chamfer_weight, self.chamfer_points = float(chamfer_weight), int(chamfer_points)
        self.selection = selection
        self.gravity_max_deg = None if gravity_max_deg is None or gravity_max_deg <= 0 else float(gravity_max_deg)
        self.refine, self.refine_max_distance, self.refine_iterations = bool(refine), float(refine_max_distance), int(refine_iterations)
        self.device, self.num_threads, self.seed = device, int(num_threads), int(seed)
        self._features: OrderedDict[str, _TemplateFeatures] = OrderedDict()

    def dictionary(self, template: Template) -> PartialDictionary:
        """The template's partial-template dictionary for this configuration (cached)."""
        return get_dictionary(template, **self.dict_args)

    # ----------------------------------------------------------------- descriptors
    # The public part (downsample_keypoints, describe, pair_affinity) is also what the
    # correspondence baselines use for ``features="lps"`` (catpose.methods.correspondence).

    def downsample_keypoints(self, points: np.ndarray, normals: np.ndarray, num_keypoints: int,
                             pad: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Voxel-downsample a cloud with ``voxel_size`` and pick keypoints by farthest point sampling.

        Args:
            points, normals: (N, 3) cloud and unit normals, any one frame.
            num_keypoints: keypoints to pick (FPS from index 0).
            pad: repeat keypoints up to ``num_keypoints`` when the downsampled cloud has fewer
                points (so partial templates batch together).

        Returns:
            downsampled points (N', 3), normals (N', 3), keypoint indices (k,) into them.
        """
        p, n = voxel_downsample(points, normals, self.voxel_size)
        idx = farthest_point_indices(p, num_keypoints)
        if pad and len(idx) < num_keypoints:
            idx = np.resize(idx, num_keypoints)
        return p, n, idx

    def describe(self, points: np.ndarray, normals: np.ndarray, kp_idx: np.ndarray, up: np.ndarray):
        """Descriptors of the keypoints ``points[kp_idx]``.

        Args:
            points, normals: (N, 3) downsampled cloud (see :meth:`downsample_keypoints`).
            kp_idx: (k,) keypoint indices.
            up: (3,) the up direction in the cloud's frame (the ground normal for the camera
                frame, ``template.up`` for the template frame); LPS frames use it.

        Returns:
            LPS ``VoxelPatches`` (or ``Patches`` for ``lps_fscore="exact"``), or (k, 125) PFH
            histograms; compare them with :meth:`pair_affinity`.
        """
        from scipy.spatial import cKDTree

        return self._describe(points, normals, kp_idx, up, cKDTree(points))

    def pair_affinity(self, desc_a, desc_b) -> np.ndarray:
        """Unnormalised affinities (k_a, k_b) between two descriptor sets from :meth:`describe`:
        the LPS F-score or the PFH 1 / (EMD + eps) that ``register`` computes batched over all
        partial templates."""
        if self.descriptor == "pfh":
            from catpose.methods.pfh import pfh_affinity

            return pfh_affinity(desc_a, desc_b, self.pfh_eps, self.pfh_distance)
        from catpose.methods.lps import fscore_exact, fscore_voxel

        if self.lps_fscore == "exact":
            return fscore_exact(desc_a, desc_b, self.lps_tau)
        return fscore_voxel(desc_a, desc_b)

    def _describe(self, points: np.ndarray, normals: np.ndarray, kp_idx: np.ndarray, ground: np.ndarray, tree):
        if self.descriptor == "pfh":
            from catpose.methods.pfh import pfh_descriptors

            return pfh_descriptors(points, normals, points[kp_idx], self.pfh_radius, self.pfh_max_nn, tree)
        from catpose.methods.lps import lps_patches, voxelize

        patches = lps_patches(points, normals, kp_idx, ground, self.lps_radius, self.lps_max_points,
                              self.lps_parallel_deg, tree)
        if self.lps_fscore == "exact":
            return patches
        return voxelize(patches, self.lps_radius, self.lps_tau, self.lps_voxel_subdiv)

    def _affinity(self, desc_c, feats: "_TemplateFeatures") -> np.ndarray:
        """Unnormalised affinities (m, n, 2n) of the input keypoints to every partial's keypoints."""
        m, k2 = feats.keypoints.shape[:2]
        if self.descriptor == "pfh":
            from catpose.methods.pfh import pfh_affinity

            if self.pfh_distance == "marginal":
                from catpose.methods.pfh import marginal_cdfs
                from scipy.spatial.distance import cdist

                emd = cdist(marginal_cdfs(desc_c), feats.stacked, metric="cityblock")
                return (1.0 / (emd + self.pfh_eps)).reshape(len(desc_c), m, k2).transpose(1, 0, 2)
            return np.stack([pfh_affinity(desc_c, d, self.pfh_eps, "exact") for d in feats.descriptors])
        from catpose.methods.lps import fscore_exact

        if self.lps_fscore == "exact":
            return np.stack([fscore_exact(desc_c, d, self.lps_tau) for d in feats.descriptors])
        # one sparse x dense product per direction over all partials at once (input grids are sparse)
        from scipy import sparse

        counts_t, dilated_t, n_t = feats.stacked
        prec = np.asarray(sparse.csr_matrix(desc_c.counts) @ dilated_t) / np.maximum(desc_c.n[:, None], 1)
        rec = np.asarray(sparse.csr_matrix(desc_c.dilated) @ counts_t) / np.maximum(n_t[None], 1)
        s = prec + rec
        f = np.where(s > 0, 2 * prec * rec / np.maximum(s, 1e-12), 0.0)
        return f.reshape(len(f), m, k2).transpose(1, 0, 2)

    def template_features(self, template: Template, dictionary: PartialDictionary) -> _TemplateFeatures:
        """Keypoints and descriptors of every partial template, cached per template and parameters."""
        from scipy.spatial import cKDTree

        key = repr((dictionary.key, tuple(np.round(np.asarray(template.up, float), 12)), self.descriptor, self.num_keypoints, self.voxel_size, self.lps_radius,
                    self.lps_tau, self.lps_max_points, self.lps_parallel_deg, self.lps_fscore,
                    self.lps_voxel_subdiv, self.pfh_radius, self.pfh_max_nn, self.chamfer_points))
        hit = self._features.get(key)
        if hit is not None:
            self._features.move_to_end(key)
            return hit
        k2 = 2 * self.num_keypoints
        up = np.asarray(template.up, dtype=np.float64)
        kps, descs = [], []
        for pts, nrm in zip(dictionary.points, dictionary.normals):
            # a tiny partial: repeat keypoints so all candidates batch together
            p, n, idx = self.downsample_keypoints(pts, nrm, k2, pad=True)
            kps.append(p[idx])
            descs.append(self._describe(p, n, idx, up, cKDTree(p)))
        complete = template.points[farthest_point_indices(template.points, self.chamfer_points)]
        stacked = None
        if self.descriptor == "pfh" and self.pfh_distance == "marginal":
            from catpose.methods.pfh import marginal_cdfs

            stacked = marginal_cdfs(np.concatenate(descs))                      # (m 2n, 15)
        elif self.descriptor == "lps" and self.lps_fscore == "voxel":
            stacked = (np.concatenate([d.counts for d in descs]).T.copy(),        # (G^3, m 2n)
                       np.concatenate([d.dilated for d in descs]).T.copy(),
                       np.concatenate([d.n for d in descs]))
        feats = _TemplateFeatures(np.stack(kps), descs, complete, cKDTree(template.points), stacked)
        self._features[key] = feats
        while len(self._features) > 8:  # LPS grids are ~25 MB a template
            self._features.popitem(last=False)
        return feats

    # ----------------------------------------------------------------- main
    def register(self, problem: RegistrationProblem) -> RegistrationResult:
        from scipy.spatial import cKDTree

        timings: dict[str, float] = {}
        t0 = time.perf_counter()
        template = problem.template
        dictionary = self.dictionary(template)
        timings["dictionary"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        feats = self.template_features(template, dictionary)
        pts, nrm, kp_idx = self.downsample_keypoints(problem.points_camera, problem.normals_camera,
                                                     self.num_keypoints)
        if len(kp_idx) < 3:
            from catpose.errors import InvalidInputError

            raise InvalidInputError(f"sample {problem.sample_id}: only {len(kp_idx)} points after voxel "
                                    f"downsampling at {self.voxel_size}; lower method.voxel_size")
        P_c = pts[kp_idx]
        desc_c = self._describe(pts, nrm, kp_idx, problem.ground_normal_camera, cKDTree(pts))
        timings["descriptors"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        A = self._affinity(desc_c, feats)                                        # (m, n, 2n)
        A = np.maximum(A, 0.0) + 1e-12
        A /= A.sum(axis=2, keepdims=True)
        timings["affinity"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        P_t = feats.keypoints                                                     # (m, 2n, 3)
        m = len(P_t)
        T0 = kabsch(np.broadcast_to(P_c, (m,) + P_c.shape), A @ P_t)
        timings["initial_pose"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        chamfer_src = pts[farthest_point_indices(pts, self.chamfer_points)]
        up = np.asarray(template.up, dtype=np.float64) / np.linalg.norm(template.up)

        def chamfer(T: np.ndarray) -> np.ndarray:
            """One-directional Chamfer distance (mean nearest-template-point distance) per pose (B,)."""
            return np.array([feats.tree.query(chamfer_src @ Ti[:3, :3].T + Ti[:3, 3])[0].mean() for Ti in T])

        def select(T: np.ndarray, losses: np.ndarray, allowed: np.ndarray):
            """Chamfer distances, tilts (deg), kept mask and criterion (inf where not kept), all (m,)."""
            dists = chamfer(T)
            g_template = np.einsum("mij,j->mi", T[:, :3, :3], problem.ground_normal_camera)
            tilt = np.degrees(np.arccos(np.clip(g_template @ up, -1.0, 1.0)))
            keep = allowed.copy()
            if self.gravity_max_deg is not None:
                keep &= tilt <= self.gravity_max_deg
                if not keep.any():  # nothing is consistent with gravity: fall back to all allowed
                    keep = allowed.copy()
            crit = losses if self.selection == "loss" else dists
            return dists, tilt, keep, np.where(keep, crit, np.inf)

        stage2 = np.arange(m)
        if self.optimize == "joint" and 0 < self.stage2_top_k < m:
            # stage 1 on all candidates, stage 2 only on the best top_k by the selection criterion
            T1, l1 = self._optimize(P_c, P_t, A, T0, chamfer_src, feats.complete_points, "pose")
            stage2 = np.sort(np.argsort(select(T1, l1, np.ones(m, bool))[3], kind="stable")[:self.stage2_top_k])
            T2, l2 = self._optimize(P_c, P_t[stage2], A[stage2], T1[stage2], chamfer_src, feats.complete_points,
                                    "joint_only")
            T, losses = T1, np.full(m, np.inf)
            T[stage2], losses[stage2] = T2, l2
        else:
            T, losses = self._optimize(P_c, P_t, A, T0, chamfer_src, feats.complete_points, self.optimize)
        timings["optimization"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        allowed = np.zeros(m, dtype=bool)
        allowed[stage2] = True
        dists, tilt_deg, keep, crit = select(T, losses, allowed)
        best = int(np.argmin(crit))
        score = float(crit[best])
        T_best = T[best]
        timings["selection"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        if self.refine:
            T_best = self._refine(pts, template, feats.tree, T_best)
            if self.selection == "chamfer":  # the score of the pose actually returned
                score = float(chamfer(T_best[None])[0])
        timings["refinement"] = time.perf_counter() - t0

        extras = {"template_index": best, "losses": [float(x) if np.isfinite(x) else None for x in losses],
                  "chamfer": [float(x) for x in dists], "tilt_deg": [float(x) for x in tilt_deg],
                  "kept": [bool(x) for x in keep], "timings": {k: float(v) for k, v in timings.items()},
                  "num_input_points": int(len(pts))}
        extras["stage2_candidates"] = [int(i) for i in stage2]
        return RegistrationResult(T_target_source=T_best, score=score, extras=extras)

    # ----------------------------------------------------------------- optimisation
    def _optimize(self, P_c: np.ndarray, P_t: np.ndarray, A: np.ndarray, T0: np.ndarray,
                  chamfer_src: np.ndarray, complete: np.ndarray, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """Two-stage Adam on all candidates at once. Returns poses (m, 4, 4) and final losses (m,)
        as mean correspondence-weighted keypoint distances (object-normalised units)."""
        import torch

        from catpose.methods.optim import BatchedProblem, _rot6d, optimize

        if self.num_threads > 0:
            torch.set_num_threads(self.num_threads)
        dev = torch.device(self.device)
        dt = torch.float32

        def tens(a):
            return torch.as_tensor(np.ascontiguousarray(a), dtype=dt, device=dev)

        use_ch = self.chamfer_weight > 0
        prob = BatchedProblem(tens(P_c), tens(P_t), tens(A), tens(chamfer_src) if use_ch else None,
                              tens(complete) if use_ch else None, self.chamfer_weight)
        n = len(P_c)
        r6 = tens(np.concatenate([T0[:, :3, 0], T0[:, :3, 1]], axis=1))
        t = tens(T0[:, :3, 3])
        stages = []
        if mode in ("pose", "joint"):
            stages.append(("pose", self.steps_pose))
        if mode in ("joint", "joint_only"):
            stages.append(("joint", self.steps_joint))
        final, _ = optimize(prob, r6, t, stages, self.lr)
        with torch.no_grad():
            R = _rot6d(r6)[0].cpu().double().numpy()
            tt = t.cpu().double().numpy()
        # re-orthonormalise in float64 so validate_pose accepts the result
        U, _, Vt = np.linalg.svd(R)
        R = U @ Vt
        T = np.tile(np.eye(4), (len(R), 1, 1))
        T[:, :3, :3], T[:, :3, 3] = R, tt
        return T, final.detach().cpu().double().numpy() / n

    def _refine(self, pts: np.ndarray, template: Template, tree, T_init: np.ndarray) -> np.ndarray:
        """Point-to-plane ICP (Chen & Medioni 1992) from ``T_init`` against the complete template.

        Written in NumPy with a KD-tree against the full complete template (no voxel averaging
        of its normals); Open3D's ICP, used by the baselines, is reproducible only on one thread
        (``catpose.o3d.max_threads``).
        ``tree`` is a KD-tree of ``template.points``. Correspondences: the nearest template point
        within ``refine_max_distance``; each step solves
        the linearised 6x6 system for a small rotation and translation.
        """
        from catpose.geometry import axis_angle_to_R

        T = T_init.copy()
        for _ in range(self.refine_iterations):
            src = pts @ T[:3, :3].T + T[:3, 3]
            d, j = tree.query(src, distance_upper_bound=self.refine_max_distance)
            ok = np.isfinite(d)
            if ok.sum() < 6:
                break
            s, q, n = src[ok], template.points[j[ok]], template.normals[j[ok]]
            J = np.concatenate([np.cross(s, n), n], axis=1)            # (k, 6)
            r = np.einsum("ij,ij->i", q - s, n)
            H = J.T @ J + 1e-9 * np.eye(6)
            x = np.linalg.solve(H, J.T @ r)
            angle = float(np.linalg.norm(x[:3]))
            dR = axis_angle_to_R(x[:3], angle) if angle > 1e-12 else np.eye(3)
            T = make_T(dR, x[3:]) @ T
            if angle < 1e-7 and np.linalg.norm(x[3:]) < 1e-7:
                break
        U, _, Vt = np.linalg.svd(T[:3, :3])
        T[:3, :3] = U @ Vt
        return T
