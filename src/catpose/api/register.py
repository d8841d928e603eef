"""``catpose.register``: one call from an observed cloud and a template to a camera pose, in the
caller's frames and unit (the methods' answer ``T_n`` in the normalised frames maps back as
``R = R_up^T R_n``, ``t = R_up^T (s t_n + c)``, see :mod:`catpose.api.inputs`)."""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from catpose.api.inputs import (
    cloud_arg,
    direction_arg,
    estimated_normals,
    normalised_template,
    normals_arg,
    oriented_to_camera,
    subsample,
)
from catpose.api.method_cache import build_method, uses_up
from catpose.errors import CatposeError, InvalidInputError
from catpose.geometry import apply_R, make_T, matmul3, norm3, unit3
from catpose.types import RegistrationProblem, RegistrationResult, Template

__all__ = ["Registration", "register", "UP_HYPOTHESES"]

#: Up directions tried (a Fibonacci sphere in the camera frame) when ``up`` is not given and the
#: method needs one (ours; a correspondence baseline with LPS features). Chosen on the synthetic
#: set, seed 0, by ``experiments/api_without_up/make_without_up.sh`` (``results/api/without_up_seed0_dev.md``).
UP_HYPOTHESES = 24


@dataclass(frozen=True, eq=False)
class Registration:
    """What :func:`register` returns; lengths in the caller's unit.

    Attributes:
        T_template_camera: (4, 4) estimated pose, ``p_template = R p_camera + t``, in the
            caller's template frame and unit.
        score: the method's own final score of that pose (lower is better): ours and the
            correspondence baselines a distance in the object-normalised unit (times ``scale``
            for the caller's unit), ICP ``1 - fitness``.
        candidates: (K, 4, 4) every hypothesis the method scored before choosing, as
            ``T_template_camera`` in the caller's frame and unit (ours: one per partial template,
            before its final refinement; ICP: one per start). With ``up=None`` and a method that
            needs gravity, the candidates of every up hypothesis, concatenated.
        candidate_scores: (K,) their scores (lower is better, inf: excluded by the method).
        method: the method's config name (or class name for an instance).
        scale: the template radius in the caller's unit (one object-normalised unit).
        up_camera: (3,) the up direction used, camera frame (given, or the best hypothesis of
            the search), or None when the method does not use one.
        extras: the method's extras (timings, chosen template index, ...) and, after an up
            search, ``up_search`` (hypotheses and their scores).
        runtime_s: wall-clock seconds of the method call(s), normalisation excluded.
    """

    T_template_camera: np.ndarray
    score: float
    candidates: np.ndarray
    candidate_scores: np.ndarray
    method: str
    scale: float
    up_camera: np.ndarray | None
    extras: Mapping[str, Any] = field(default_factory=dict)
    runtime_s: float = float("nan")


def register(
    observation: Any,
    template: Any,
    method: str | Any = "ours",
    up: Sequence[float] | None = None,
    *,
    observation_normals: Any = None,
    template_normals: Any = None,
    template_up: Sequence[float] = (0.0, 0.0, 1.0),
    max_points: int = 2048,
    template_points: int = 2048,
    up_hypotheses: int = UP_HYPOTHESES,
    **options: Any,
) -> Registration:
    """Estimate the camera pose ``T_template_camera`` of a partial view of an object.

    Args:
        observation: (N, 3) observed surface points in the camera frame, any unit (the same as
            the template's); segmented (only the object).
        template: the object or category template in its own frame: an (M, 3) point array, a
            ``trimesh.Trimesh``, a ``(vertices (V, 3), faces (F, 3))`` pair, or the path of an
            OFF, OBJ or PLY mesh. A mesh is sampled on its outer surface (``template_points``).
        method: a config name, ``ours`` (the paper's method), ``icp``, ``fgr``, ``ransac``,
            ``teaser`` (``configs/method/<name>.yaml``, built as ``bench run`` builds it), or a
            :class:`~catpose.methods.method.RegistrationMethod` instance.
        up: the template's up direction (``template_up``) seen in the camera frame, i.e. the
            ground plane's normal pointing away from the ground (3,). ICP and the FPFH/PFH
            baselines do not use it. Ours does (LPS descriptor frames and its gravity filter):
            without it, ours is run once per direction of ``up_hypotheses`` spread over the
            sphere and the best-scoring answer is kept, which costs up to ``up_hypotheses``
            times the time and can be less accurate (figures: docs/api.md, quoting
            ``results/api/without_up_*.md``).
        observation_normals: (N, 3) normals of ``observation`` (any orientation: they are turned
            towards the camera), or None to estimate them by local plane fits (radius 0.1
            template radii, as the datasets do).
        template_normals: (M, 3) outward normals of a point-cloud template, or None to estimate
            them (oriented away from the template's bounding-box centre: right for convex-ish
            shapes; pass them for shapes with deep concavities).
        template_up: the template's up axis in its own frame (default +z).
        max_points: the observation keeps at most this many points (seeded random subset, after
            normal estimation; 0 keeps all), as the datasets do.
        template_points: points sampled on a mesh template, or kept of a cloud template.
        up_hypotheses: up directions tried when ``up`` is None and the method needs one.
        **options: method options as in ``bench run`` (``method.<key>=<value>``), e.g.
            ``voxel_size=0.05`` (icp), ``selection={"gravity_max_deg": None}`` or
            ``descriptor="pfh"`` (ours). Ignored when ``method`` is an instance (pass none).

    Returns:
        a :class:`Registration` in the caller's frames and unit.

    Raises:
        InvalidInputError: a bad argument, in one line naming it.

    Deterministic: the same inputs give the same answer (the global NumPy, torch and Open3D
    seeds are set before each method call, as ``bench run`` does per sample).
    """
    pts = cloud_arg("observation", observation)
    obs_normals = normals_arg("observation_normals", observation_normals, pts)
    t_up = direction_arg("template_up", template_up)
    up_camera = None if up is None else direction_arg("up", up)
    for name, value in (
        ("max_points", max_points),
        ("template_points", template_points),
        ("up_hypotheses", up_hypotheses),
    ):
        least = 0 if name == "max_points" else 1
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            raise InvalidInputError(f"{name}={value!r} is not a positive integer")
    if isinstance(method, str):
        method_name, impl = method, build_method(method, **options)
    else:
        if not callable(getattr(method, "register", None)):
            raise InvalidInputError(
                f"method is a {type(method).__name__}; pass a config name "
                "(ours, icp, fgr, ransac, teaser) or a RegistrationMethod instance"
            )
        if options:
            raise InvalidInputError(
                f"options {sorted(options)} apply to a method config name, not to an instance; set them on the instance"
            )
        method_name, impl = type(method).__name__, method

    tmpl, R_up, centre, scale = normalised_template(template, template_normals, t_up, int(template_points))
    points = pts / scale
    radius = float(norm3(points - 0.5 * (points.min(axis=0) + points.max(axis=0))).max())
    if radius > 2.0:
        warnings.warn(
            f"catpose.register: the observation spans {radius:.1f} template radii; check that both clouds "
            "use the same unit and that the observation holds only the object",
            stacklevel=2,
        )
    normals = oriented_to_camera(points, obs_normals) if obs_normals is not None else estimated_normals(points)
    keep = subsample(len(points), int(max_points), "observation")
    if keep is not None:
        points, normals = points[keep], normals[keep]

    needs_up = uses_up(impl)
    if up_camera is not None or not needs_up:
        # R_up maps template-frame directions into the normalised frame; the camera frame is not rotated
        g = up_camera if up_camera is not None else np.array([0.0, -1.0, 0.0])  # unused by this method
        t0 = time.perf_counter()
        result = _call(impl, _problem(points, normals, g, tmpl))
        runtime = time.perf_counter() - t0
        chosen_up, extras = (up_camera if needs_up or up_camera is not None else None), dict(result.extras)
        cands, scores = _candidates(result)
    else:
        from catpose.datasets.meshio import fibonacci_sphere

        t0 = time.perf_counter()
        tried = []
        for g in fibonacci_sphere(int(up_hypotheses)):
            try:
                tried.append((g, _call(impl, _problem(points, normals, unit3(g), tmpl))))
            except InvalidInputError:
                raise
            except CatposeError:  # a hypothesis without an answer (no correspondences): the others decide
                continue
        runtime = time.perf_counter() - t0
        if not tried:
            raise InvalidInputError("observation: no up hypothesis gave a pose; pass up (the ground normal)")
        best = min(range(len(tried)), key=lambda i: (not np.isfinite(tried[i][1].score), tried[i][1].score))
        chosen_up, result = tried[best]
        extras = dict(result.extras)
        extras["up_search"] = {
            "hypotheses": [[float(x) for x in g] for g, _ in tried],
            "scores": [float(r.score) for _, r in tried],
            "chosen": best,
        }
        parts = [_candidates(r) for _, r in tried]
        cands, scores = np.concatenate([c for c, _ in parts]), np.concatenate([s for _, s in parts])

    to_caller = lambda T: _to_caller(T, R_up, centre, scale)  # noqa: E731
    return Registration(
        T_template_camera=to_caller(np.asarray(result.T_template_camera, float)),
        score=float(result.score),
        candidates=np.stack([to_caller(T) for T in cands]),
        candidate_scores=scores,
        method=method_name,
        scale=float(scale),
        up_camera=None if chosen_up is None else np.asarray(chosen_up, float),
        extras=extras,
        runtime_s=runtime,
    )


def _problem(points: np.ndarray, normals: np.ndarray, g: np.ndarray, template: Template) -> RegistrationProblem:
    try:
        return RegistrationProblem(
            sample_id="catpose.register",
            category="object",
            points_camera=points,
            normals_camera=normals,
            ground_normal_camera=g,
            template=template,
        )
    except CatposeError as e:
        raise InvalidInputError(str(e).replace("sample catpose.register: observed cloud", "observation")) from None


def _call(method: Any, problem: RegistrationProblem) -> RegistrationResult:
    """``method.register(problem)`` with the global seeds set as ``bench run`` sets them."""
    from catpose.bench.run.sample_run import seed_everything

    seed_everything(0)
    return method.register(problem)


def _candidates(result: RegistrationResult) -> tuple[np.ndarray, np.ndarray]:
    if result.candidates_T is None or len(result.candidates_T) == 0:
        return np.asarray(result.T_template_camera, float)[None], np.array([float(result.score)])
    return np.asarray(result.candidates_T, float), np.asarray(result.candidate_scores, float)


def _to_caller(T_n: np.ndarray, R_up: np.ndarray, centre: np.ndarray, scale: float) -> np.ndarray:
    """``T_template_camera`` in the caller's frame and unit from the normalised estimate ``T_n``."""
    return make_T(matmul3(R_up.T, T_n[:3, :3]), apply_R(R_up.T, scale * T_n[:3, 3] + centre))
