"""Point pair features (Drost, Ulrich, Navab, Ilic, CVPR 2010) through OpenCV's ``ppf_match_3d``.

The classic depth-only peer of BOP, as OpenCV's contrib build ships it (the optional extra ``ppf``,
``opencv-contrib-python-headless``):

1. **Model** (once per template and setting): the template's points and outward normals,
   voxel-downsampled at ``model_sampling`` times its diameter (bounding-box diagonal, OpenCV's),
   train ``PPF3DDetector``, whose feature distance step is the same ``model_sampling`` (its
   ``relativeDistanceStep`` is not read).
2. **Detection**: the observation (camera frame, normals towards the camera) voxel-downsampled at
   ``scene_sampling`` x the diameter; every ``scene_reference_step``-th point votes. OpenCV grids
   the scene relative to the *scene's* bounding box, so stray points far behind the object would
   coarsen it: the voxels here are absolute and OpenCV's grid is set finer (at most
   :data:`MAX_SCENE_CELLS` a side; ``scene_grid_capped`` in the extras when that cap bit).
3. **Refinement**: OpenCV's ICP of each of the ``top_k`` most voted pose clusters, with the
   template points facing the camera under that pose (``icp_model``).
4. **Choice** (``select``): ``votes``, ``residual`` (ICP's) or ``chamfer`` (the observation's mean
   distance to the posed template, the score every correspondence baseline reports).

OpenCV's pose maps the model into the scene; the answer is its inverse, ``T_template_camera``.
Trained detectors stay for the process's life (:data:`_MODELS`; training takes seconds to minutes,
and the Python binding cannot write a model to disk).
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from catpose.content_hash import template_key
from catpose.errors import ConfigError, InvalidInputError
from catpose.geometry import invert_T, transform_points
from catpose.lru import LRUCache
from catpose.methods import options
from catpose.methods.keypoints import voxel_downsample
from catpose.methods.method import RegistrationMethod
from catpose.methods.registry import SuiteRow, register_method
from catpose.types import RegistrationProblem, RegistrationResult, Template

log = logging.getLogger(__name__)

SELECTIONS = ("votes", "residual", "chamfer")

#: fewer template points facing the camera than this: ICP takes all of them
MIN_ICP_POINTS = 32

ICP_MODELS = ("visible", "all")

#: OpenCV allocates (cells + 1)^3 lists for its scene grid: 100 a side is 1e6 lists (~24 MB)
MAX_SCENE_CELLS = 100

_MISSING = (
    "method=ppf needs OpenCV's contrib build (cv2.ppf_match_3d): install it with "
    "pip install -e '.[ppf]' (or pip install opencv-contrib-python-headless) in place of any other opencv-python"
)

#: trained detectors of this process, by (template content, model settings): see the module docstring
_MODELS: LRUCache[tuple, tuple[Any, np.ndarray, float]] = LRUCache(16)


def import_ppf():
    """OpenCV's ``ppf_match_3d`` module, or :class:`ConfigError` saying how to install it."""
    try:
        import cv2
    except ImportError:
        raise ConfigError(_MISSING) from None
    module = getattr(cv2, "ppf_match_3d", None)
    if module is None:
        raise ConfigError(_MISSING + f" (this OpenCV {cv2.__version__} has no contrib modules)")
    return module


def diameter(points: np.ndarray) -> float:
    """The diagonal of the bounding box of ``points`` (N, 3): OpenCV's object diameter."""
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def cloud_array(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(N, 6) float32 ``x y z nx ny nz``, C-contiguous: OpenCV's point cloud with normals."""
    return np.ascontiguousarray(np.hstack([points, normals]), dtype=np.float32)


@register_method(
    "ppf",
    "PPF",
    suite=(SuiteRow("ppf", rank=9),),
    requires="cv2.ppf_match_3d",  # OpenCV's contrib build: the extra ppf
    smoke_options={"model_sampling": 0.08},  # coarse: trains in well under a second
)
class PPF(RegistrationMethod):
    """Point pair features and ICP, OpenCV's implementation.

    Args:
        model_sampling: the model's sampling step and feature distance step, relative to the
            template's diameter (OpenCV's ``relativeSamplingStep``).
        num_angles: quantisation of the feature angles (OpenCV's ``numAngles``, 30 by default).
        scene_sampling: voxel of the observation, relative to the template's diameter.
        scene_reference_step: every n-th sampled observation point is a reference point
            (OpenCV's ``relativeSceneSampleStep`` = 1 / n).
        top_k: pose clusters (most votes first) refined by ICP.
        select: ``votes`` | ``residual`` | ``chamfer``: which refined pose is returned.
        icp_iterations, icp_tolerance, icp_rejection_scale, icp_levels: OpenCV's ICP (iterations,
            relative change that stops a level, robust rejection scale, pyramid levels).
        icp_model: ``visible`` (the template's points facing the camera under each pose) or
            ``all`` (OpenCV's own use, which pulls a complete model towards a partial view).
    """

    def __init__(
        self,
        model_sampling: float = 0.05,
        num_angles: int = 20,
        scene_sampling: float = 0.05,
        scene_reference_step: int = 5,
        top_k: int = 20,
        select: str = "chamfer",
        icp_iterations: int = 100,
        icp_tolerance: float = 0.005,
        icp_rejection_scale: float = 2.5,
        icp_levels: int = 4,
        icp_model: str = "visible",
    ) -> None:
        # fractions of the object's diameter
        self.model_sampling = options.within("method.model_sampling", model_sampling, 0, 1)
        self.scene_sampling = options.within("method.scene_sampling", scene_sampling, 0, 1)
        self.num_angles = options.at_least("method.num_angles", num_angles, 4)
        self.scene_reference_step = options.positive("method.scene_reference_step", scene_reference_step, integer=True)
        self.top_k = options.positive("method.top_k", top_k, integer=True)
        self.select = options.one_of("method.select", select, SELECTIONS)
        self.icp_iterations = options.non_negative("method.icp_iterations", icp_iterations, integer=True)
        self.icp_tolerance = options.positive("method.icp_tolerance", icp_tolerance)
        self.icp_rejection_scale = options.non_negative("method.icp_rejection_scale", icp_rejection_scale)
        self.icp_levels = options.positive("method.icp_levels", icp_levels, integer=True)
        self.icp_model = options.one_of("method.icp_model", icp_model, ICP_MODELS)
        import_ppf()  # a missing OpenCV contrib build is a config error before any sample runs

    # ------------------------------------------------------------------ the model
    def model(self, template: Template) -> tuple[Any, np.ndarray, float]:
        """(trained ``PPF3DDetector``, the (M, 6) model cloud given to it, diameter), trained on
        the first call per template content and model settings in this process."""
        key = (template_key(template), self.model_sampling, self.num_angles)
        hit = _MODELS.get(key)
        if hit is not None:
            return hit
        ppf = import_ppf()
        d = diameter(template.points)
        points, normals = voxel_downsample(template.points, template.normals, self.model_sampling * d)
        cloud = cloud_array(points, normals)
        log.info("ppf: training the model of %s (%d points) ...", template.template_id, len(cloud))
        t0 = time.perf_counter()
        detector = ppf.PPF3DDetector(self.model_sampling, self.model_sampling, float(self.num_angles))
        detector.trainModel(cloud)
        log.info("ppf: trained %s in %.1f s", template.template_id, time.perf_counter() - t0)
        _MODELS.put(key, (detector, cloud, d))
        return detector, cloud, d

    # ------------------------------------------------------------------ refinement
    def _refine(self, pose: Any, problem: RegistrationProblem) -> Any:
        """OpenCV's ICP from one detected ``Pose3D``: the template's points whose normals face the
        camera under that pose (``icp_model=visible``; all of them for ``all``, and for an
        observation not all in front of the camera, which no camera saw) onto the observation."""
        ppf = import_ppf()
        template = problem.template
        points, normals = template.points, template.normals
        if self.icp_model == "visible" and (problem.points_camera[:, 2] > 0).all():  # else no camera saw it
            T = np.asarray(pose.pose, dtype=np.float64)
            facing = np.einsum("ij,ij->i", normals @ T[:3, :3].T, transform_points(T, points)) < 0
            if facing.sum() >= MIN_ICP_POINTS:
                points, normals = points[facing], normals[facing]
        icp = ppf.ICP(self.icp_iterations, self.icp_tolerance, self.icp_rejection_scale, self.icp_levels)
        _, refined = icp.registerModelToScene(
            cloud_array(points, normals), cloud_array(problem.points_camera, problem.normals_camera), [pose]
        )
        return refined[0]

    # ------------------------------------------------------------------ registration
    def register(self, problem: RegistrationProblem) -> RegistrationResult:
        from scipy.spatial import cKDTree

        timings: dict[str, float] = {}
        t0 = time.perf_counter()
        detector, model_cloud, d = self.model(problem.template)
        timings["model_s"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        points, normals = voxel_downsample(problem.points_camera, problem.normals_camera, self.scene_sampling * d)
        if len(points) < 3:
            raise InvalidInputError(
                f"sample {problem.sample_id}: {len(points)} observed points after sampling at "
                f"{self.scene_sampling} of the diameter; lower method.scene_sampling"
            )
        scene = cloud_array(points, normals)
        extent = float((points.max(axis=0) - points.min(axis=0)).max())
        # OpenCV's own grid over the scene's bounding box: cells of at most half a voxel
        cells = int(np.ceil(2.0 * extent / (self.scene_sampling * d))) if extent > 0 else 1
        capped = cells > MAX_SCENE_CELLS
        cells = min(max(cells, 1), MAX_SCENE_CELLS)
        results = detector.match(scene, 1.0 / self.scene_reference_step, 1.0 / cells)
        timings["match_s"] = time.perf_counter() - t0
        if not results:
            raise InvalidInputError(f"sample {problem.sample_id}: PPF found no pose (no feature of the view voted)")

        t0 = time.perf_counter()
        top = list(results[: self.top_k])
        votes = [int(p.numVotes) for p in top]
        if self.icp_iterations > 0:
            top = [self._refine(p, problem) for p in top]
        timings["icp_s"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        T_camera_template = np.stack([np.asarray(p.pose, dtype=np.float64) for p in top])
        if not np.isfinite(T_camera_template).all():
            raise InvalidInputError(f"sample {problem.sample_id}: OpenCV's PPF or ICP returned a non-finite pose")
        T = np.stack([invert_T(x) for x in T_camera_template])
        residual = np.array([float(p.residual) for p in top]) if self.icp_iterations > 0 else np.zeros(len(top))
        tree = cKDTree(problem.template.points)
        chamfer = np.array([float(np.mean(tree.query(transform_points(x, problem.points_camera))[0])) for x in T])
        if self.select == "votes":
            best = 0
        elif self.select == "residual":
            best = int(np.argmin(residual))
        else:
            best = int(np.argmin(chamfer))
        timings["select_s"] = time.perf_counter() - t0
        extras = {
            "model_points": int(len(model_cloud)),
            "scene_points": int(len(scene)),
            "scene_grid_cells": cells,
            "scene_grid_capped": capped,
            "num_clusters": int(len(results)),
            "chosen_index": best,
            "votes": votes,
            "icp_residual": [float(r) for r in residual],
            "candidate_chamfer": [float(c) for c in chamfer],
            **timings,
        }
        return RegistrationResult(
            T_template_camera=T[best],
            score=float(chamfer[best]),
            extras=extras,
            candidates_T=T,
            candidate_scores=chamfer,
        )
