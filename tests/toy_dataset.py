"""A tiny dataset and methods for runner tests (importable once ``tests/`` is on sys.path).

The object is an L-shaped block (no symmetry); observations are rendered views. Special ids
exercise the failure paths: ``load_error`` (the loader raises), ``empty`` (no points), ``nan``
(NaN coordinates) and ``collinear`` (all points on a line).
"""

from __future__ import annotations

import os

import numpy as np
import trimesh

from catpose.datasets.dataset import ObjectDataset, Observation
from catpose.datasets.render import PinholeCamera, depth_to_points, estimate_normals, render_depth
from catpose.datasets.views import ViewOptions
from catpose.errors import DatasetError
from catpose.geometry import invert_T, normalize_to_unit_sphere, stable_seed
from catpose.methods.method import RegistrationMethod
from catpose.types import RegistrationResult, Template


def l_block() -> trimesh.Trimesh:
    a = trimesh.creation.box(extents=[1.0, 0.6, 0.3])
    b = trimesh.creation.box(extents=[0.25, 0.6, 0.6])
    b.apply_translation([0.375, 0.0, 0.45])
    m = trimesh.util.concatenate([a, b])
    v, _, _ = normalize_to_unit_sphere(m.vertices)
    return trimesh.Trimesh(v, m.faces, process=False)


class ToyDataset(ObjectDataset):
    def __init__(self, seed: int = 0, num_views: int = 4, special: list[str] | None = None) -> None:
        self.seed, self.num_views, self.special = seed, num_views, list(special or [])
        self.mesh = l_block()
        pts, fi = trimesh.sample.sample_surface(self.mesh, 3000, seed=0)
        self.template = Template(
            "toy/block/0",
            "block",
            pts,
            self.mesh.face_normals[fi],
            np.asarray(self.mesh.vertices),
            np.asarray(self.mesh.faces),
        )
        self.camera = PinholeCamera(160, 120, 110.0, 110.0, 79.5, 59.5)

    def observation_ids(self) -> list[str]:
        return [f"block/0/v{i}" for i in range(self.num_views)] + [f"block/0/{s}" for s in self.special]

    def observation(self, obs_id: str) -> Observation:
        kind = obs_id.rsplit("/", 1)[1]
        if kind == "load_error":
            raise DatasetError(f"{obs_id}: file is malformed on purpose")
        T_camera_object = ViewOptions(distance=3.0).sample(np.random.default_rng(stable_seed(self.seed, obs_id)))
        points, _ = depth_to_points(
            render_depth(self.mesh.vertices, self.mesh.faces, T_camera_object, self.camera), self.camera
        )
        normals = estimate_normals(points, radius=0.1)
        if kind == "empty":
            points, normals = points[:0], normals[:0]
        elif kind == "nan":
            points = points.copy()
            points[3] = np.nan
        elif kind == "collinear":
            points = np.outer(np.linspace(0, 1, 50), [1.0, 2.0, 3.0])
            normals = np.tile([0.0, 0.0, -1.0], (50, 1))
        return Observation(
            obs_id, "block", "0", points, normals, T_camera_object[:3, :3] @ [0.0, 0.0, 1.0], invert_T(T_camera_object)
        )

    def instance_model(self, category: str, instance_id: str) -> Template:
        return self.template

    def category_templates(self, category: str) -> list[Template]:
        return [self.template]


class Oracle(RegistrationMethod):
    """Returns a fixed pose; counts its calls in ``count_file`` (to prove resume does no work)."""

    def __init__(self, count_file: str = "", fail_on: list[str] | None = None, nan_on: list[str] | None = None):
        self.count_file, self.fail_on, self.nan_on = count_file, list(fail_on or []), list(nan_on or [])

    def register(self, problem):
        if self.count_file:
            with open(self.count_file, "a") as f:
                f.write(problem.sample_id + "\n")
        interrupt_on = os.environ.get("TOY_INTERRUPT_ON")  # not in the config: same run directory
        if interrupt_on and problem.sample_id.endswith(interrupt_on):
            raise KeyboardInterrupt  # as if the user pressed Ctrl-C in the middle of a run
        if any(problem.sample_id.endswith(s) for s in self.fail_on):
            raise RuntimeError("method blew up on purpose")
        T = np.eye(4)
        if any(problem.sample_id.endswith(s) for s in self.nan_on):
            T[0, 0] = np.nan
        return RegistrationResult(T_template_camera=T, score=float(len(problem.points_camera)))


class BatchOracle(Oracle):
    """:class:`Oracle` with ``register_batch``: one call for several problems (logged as
    ``batch:<n>``), failing as a whole when one of them fails, as a solver launch does."""

    def register_batch(self, problems):
        if self.count_file:
            with open(self.count_file, "a") as f:
                f.write(f"batch:{len(problems)}\n")
        if any(p.sample_id.endswith(s) for p in problems for s in self.fail_on):
            raise RuntimeError("one problem of the batch blew up on purpose")
        return [Oracle.register(self, p) for p in problems]


class Planted(RegistrationMethod):
    """Answers 90 degrees off the truth, after a search whose ``candidates`` stage holds the truth
    (``plant=True``) or only a pose 45 degrees off it (``extras["hypothesis_stages"]``). The truth
    comes from the dataset's own view sampler (seeded by the sample id), as a test's knowledge, not
    a method's: it checks that the runner scores hypothesis recall, found or never found. Its
    runner-up (``extras["runner_up"]``) is the best pose of ``candidates``."""

    def __init__(self, seed: int = 0, plant: bool = True) -> None:
        self.seed, self.plant = seed, bool(plant)

    def register(self, problem):
        from catpose.geometry import axis_angle_to_R, compose_T, make_T

        T_camera_object = ViewOptions(distance=3.0).sample(
            np.random.default_rng(stable_seed(self.seed, problem.sample_id))
        )
        truth = invert_T(T_camera_object)

        def turned(deg: float) -> np.ndarray:
            return compose_T(make_T(axis_angle_to_R(np.array([1.0, 0.0, 0.0]), np.radians(deg)), np.zeros(3)), truth)

        stages = {"candidates": [turned(45.0)] + ([truth] if self.plant else []), "final": [turned(90.0)]}
        second = {"T_template_camera": stages["candidates"][-1].tolist(), "cost": 0.01, "margin": 0.01}
        return RegistrationResult(
            T_template_camera=turned(90.0),
            score=0.0,
            extras={"hypothesis_stages": {k: np.stack(v).tolist() for k, v in stages.items()}, "runner_up": second},
        )
