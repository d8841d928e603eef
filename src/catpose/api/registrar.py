"""``catpose.Registrar``: one template held between calls, its method's per-template data built
once (and kept in the disk cache, so that another process loads it). ``registrar(observation)``
registers one view. :func:`catpose.register` is a one-off Registrar.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.api.inputs import NormalisedTemplate, direction_arg, normalised_template, unit_warning
from catpose.api.method_cache import build_method
from catpose.api.observation import Observed, observed
from catpose.api.result import Registration
from catpose.errors import CatposeError, InvalidInputError, RegistrationFailed
from catpose.geometry import apply_R, make_T, matmul3, seed_everything, unit3
from catpose.methods import registry
from catpose.types import RegistrationProblem, RegistrationResult

__all__ = ["Registrar", "UP_HYPOTHESES"]

#: Up directions tried (a Fibonacci sphere in the camera frame) when ``up`` is not given and the
#: method needs one (ours; a correspondence baseline with LPS features). Chosen on the synthetic
#: set, seed 0, by ``experiments/api_without_up/make_without_up.sh`` (``results/api/without_up_seed0_dev.md``).
UP_HYPOTHESES = 24


def _count(name: str, value: Any, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise InvalidInputError(f"{name}={value!r} is not a positive integer")
    return int(value)


class Registrar:
    """A template and a method, ready to register views of the template's object.

    Args:
        template, method, template_normals, template_up, template_points, **options: as
            :func:`catpose.register`.
        prepare: build the method's per-template data now (ours: dictionaries, descriptors, ray
            caster; loaded from the disk cache when there); False: on the first call.

    Raises:
        InvalidInputError: a bad argument or option, in one line naming it.
    """

    def __init__(
        self,
        template: Any,
        method: str | Any = "ours",
        *,
        template_normals: Any = None,
        template_up: Sequence[float] = (0.0, 0.0, 1.0),
        template_points: int = 2048,
        prepare: bool = True,
        **options: Any,
    ) -> None:
        if isinstance(method, str):
            self.method_name, self.method = method, build_method(method, **options)
        else:
            if not callable(getattr(method, "register", None)):
                raise InvalidInputError(
                    f"method is a {type(method).__name__}; pass a config name "
                    "(ours, icp, gicp, ...: catpose.methods.registry) or a RegistrationMethod instance"
                )
            if options:
                raise InvalidInputError(
                    f"options {sorted(options)} apply to a method config name, not to an instance; "
                    "set them on the instance"
                )
            self.method_name, self.method = type(method).__name__, method
        t_up = direction_arg("template_up", template_up)
        points = _count("template_points", template_points, 1)
        self.template: NormalisedTemplate = normalised_template(template, template_normals, t_up, points)
        self.needs_up = registry.needs_up(self.method)
        if prepare:
            registry.prepare(self.method, self.template.template)

    def __call__(
        self,
        observation: Any,
        up: Sequence[float] | None = None,
        *,
        observation_normals: Any = None,
        max_points: int = 2048,
        up_hypotheses: int = UP_HYPOTHESES,
        plane_distance: float | None = None,
        _stacklevel: int = 2,
    ) -> Registration:
        """Register one view; arguments as :func:`catpose.register`."""
        up_camera = None if up is None else direction_arg("up", up)
        max_points = _count("max_points", max_points, 0)
        up_hypotheses = _count("up_hypotheses", up_hypotheses, 1)
        if up_hypotheses > 1000:
            raise InvalidInputError(f"up_hypotheses={up_hypotheses} is more than 1000; 24 is the default")
        obs = observed(
            observation,
            self.template,
            up=up_camera,
            observation_normals=observation_normals,
            max_points=max_points,
            plane_distance=plane_distance,
        )
        message = unit_warning(obs.radius, "observation" if obs.depth_image is None else "mask's points")
        if message:
            warnings.warn(message, stacklevel=_stacklevel + 1)
        return self._register(obs, up_hypotheses)

    # ------------------------------------------------------------------ internals
    def _register(self, obs: Observed, up_hypotheses: int) -> Registration:
        tmpl = self.template
        if obs.ground is not None or not self.needs_up:
            g = obs.ground if obs.ground is not None else np.array([0.0, -1.0, 0.0])  # unused by this method
            t0 = time.perf_counter()
            result = self._call(obs, g)
            runtime = time.perf_counter() - t0
            chosen_up = obs.ground
            extras = dict(result.extras)
            cands, scores = _candidates(result)
        else:
            from catpose.datasets.meshio import fibonacci_sphere

            t0 = time.perf_counter()
            tried, why = [], ""
            for g in fibonacci_sphere(int(up_hypotheses)):
                try:
                    tried.append((g, self._call(obs, unit3(g))))
                except RegistrationFailed as e:  # a hypothesis without an answer: the others decide
                    why = str(e)
                    continue
            runtime = time.perf_counter() - t0
            if not tried:
                raise RegistrationFailed(
                    f"method {self.method_name!r}: no up hypothesis gave a pose (the last: {why}); pass up (the ground normal)"
                )
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
        extras.update({k: v for k, v in obs.facts.items() if k != "ground"}, ground_source=obs.facts["ground"])
        second = result.runner_up
        return Registration(
            T_template_camera=_to_caller(np.asarray(result.T_template_camera, float), tmpl),
            score=float(result.score),
            candidates=np.stack([_to_caller(T, tmpl) for T in cands]),
            candidate_scores=scores,
            method=self.method_name,
            scale=float(tmpl.scale),
            up_camera=None if chosen_up is None else np.asarray(chosen_up, float),
            extras=extras,
            runtime_s=runtime,
            T_normalised=np.asarray(result.T_template_camera, float),
            runner_up=None if second is None else _to_caller(second[0], tmpl),
            runner_up_margin=float("nan") if second is None else second[1],
        )

    def _call(self, obs: Observed, g: np.ndarray) -> RegistrationResult:
        """The method on one problem, seeded as ``bench run`` seeds a sample; a method's failure
        on valid input is :class:`RegistrationFailed` (the input was checked above)."""
        try:
            problem = RegistrationProblem(
                sample_id=obs.sample_id,
                category=self.template.template.category,
                points_camera=obs.points,
                normals_camera=obs.normals,
                ground_normal_camera=g,
                template=self.template.template,
                depth_image=obs.depth_image,
            )
        except CatposeError as e:
            raise InvalidInputError(str(e).replace(f"sample {obs.sample_id}: observed cloud", "observation")) from None
        seed_everything(obs.seed)
        try:
            return self.method.register(problem)
        except CatposeError as e:
            why = str(e).replace(f"sample {obs.sample_id}: ", "")
            raise RegistrationFailed(f"method {self.method_name!r} gave no pose: {why}") from None


def _candidates(result: RegistrationResult) -> tuple[np.ndarray, np.ndarray]:
    if result.candidates_T is None or len(result.candidates_T) == 0:
        return np.asarray(result.T_template_camera, float)[None], np.array([float(result.score)])
    return np.asarray(result.candidates_T, float), np.asarray(result.candidate_scores, float)


def _to_caller(T_n: np.ndarray, tmpl: NormalisedTemplate) -> np.ndarray:
    """``T_template_camera`` in the caller's frame and unit from the normalised estimate ``T_n``:
    ``R = R_up^T R_n``, ``t = R_up^T (s t_n + c)``."""
    R_up = tmpl.R_up
    return make_T(matmul3(R_up.T, T_n[:3, :3]), apply_R(R_up.T, tmpl.scale * T_n[:3, 3] + tmpl.centre))
