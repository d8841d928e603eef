"""Small shapes with known poses for the tests of the paper's method (no external files)."""

from __future__ import annotations

import numpy as np

from catpose.datasets.render import PinholeCamera, depth_to_points, estimate_normals, render_depth
from catpose.datasets.views import ViewOptions
from catpose.geometry import invert_T
from catpose.types import RegistrationProblem, Template

CAMERA = PinholeCamera(160, 120, 150.0, 150.0, 80.0, 60.0)


def chair_mesh() -> tuple[np.ndarray, np.ndarray]:
    """An asymmetric chair-like union of boxes (seat, back, four legs, an arm on one side)."""
    import trimesh

    parts = [
        ((0.8, 0.8, 0.1), (0, 0, 0)),
        ((0.1, 0.8, 0.8), (-0.35, 0, 0.45)),
        ((0.08, 0.08, 0.5), (0.35, 0.35, -0.3)),
        ((0.08, 0.08, 0.5), (0.35, -0.35, -0.3)),
        ((0.08, 0.08, 0.5), (-0.35, 0.35, -0.3)),
        ((0.08, 0.08, 0.5), (-0.35, -0.35, -0.3)),
        ((0.6, 0.08, 0.25), (0.0, 0.36, 0.15)),
    ]
    meshes = [
        trimesh.creation.box(extents=e, transform=trimesh.transformations.translation_matrix(c)) for e, c in parts
    ]
    m = trimesh.util.concatenate(meshes)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def chair_template(n_points: int = 2048) -> Template:
    from catpose.datasets.meshio import mesh_to_template

    v, f = chair_mesh()
    return mesh_to_template(v, f, "test/chair", "chair", n_points=n_points, seed=0)


def partial_problem(template: Template, seed: int) -> tuple[RegistrationProblem, np.ndarray]:
    """A rendered partial view of ``template``'s mesh at a seeded viewpoint; returns the problem
    and the true ``T_template_camera``."""
    rng = np.random.default_rng(seed)
    T_camera_object = ViewOptions(distance=3.0).sample(rng)
    depth = render_depth(template.vertices, template.triangles, T_camera_object, CAMERA)
    pts, _ = depth_to_points(depth, CAMERA)
    nrm = estimate_normals(pts, radius=0.06)
    g = T_camera_object[:3, :3] @ np.array([0.0, 0.0, 1.0])
    return RegistrationProblem(f"seed{seed}", template.category, pts, nrm, g, template), invert_T(T_camera_object)


def rotation_error_deg(R_est: np.ndarray, R_gt: np.ndarray) -> float:
    c = (np.trace(R_est.T @ R_gt) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
