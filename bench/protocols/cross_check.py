"""How well one view's estimate fits each of its category's K templates (``info["cross_costs"]``,
read by the ``cross`` choice rule of :mod:`catpose.bench.protocols.template_choice`).

The K templates share the category's canonical frame, so a right estimate from any template is
a pose the other templates also fit, after a small correction for their different shapes; an
estimate that is a quarter or half turn off fits its own template by a shape coincidence that the
other templates do not share. For the estimate ``T`` (camera -> template ``k``) of a view:

- on its own template ``k`` the cost is the visibility-aware two-directional Chamfer distance
  (:func:`catpose.methods.pose_scores.visibility_chamfer`, truncated at ``TRUNC``) at ``T`` itself;
- on every other template ``j`` it is the same distance after point-to-plane ICP of the view
  against template ``j`` from ``T`` (Open3D, within ``ICP_DISTANCE``, at most ``ICP_ITERATIONS``);
- each of those poses also pays ``SILHOUETTE_WEIGHT x (1 - IoU)`` of the view's and the posed
  template's silhouettes (:func:`silhouette_iou`): a chair turned a quarter shows the camera a
  seat as wide as it is deep and a back seen edge-on, an outline the view does not have even where
  the Chamfer distances tie.

Beside the K costs, :func:`top_offset` (read by the ``cross_top`` rule) places the estimate's top part: the horizontal distance
(across the template frame's up) between the centroid of the view's highest ``TOP_FRACTION``
points, posed by the estimate, and the mean of the K templates' own top centroids. The templates
share the category's frame, so they agree where a category's highest part stands (a chair's back,
an airplane's tail fin); a quarter-turned chair puts its back at the side, a nose/tail-swapped
airplane its fin at the nose, even where the Chamfer distances and silhouettes tie.

:func:`turn_candidates` (read by the ``cross_top_turns`` rule) proposes more poses from each
estimate: the estimate turned by each of ``TURNS_DEG`` about the template frame's up, refined by
the same ICP on its own template, each with its own costs and top offset. A chair's seat is often
as wide as it is deep, so a registration can settle a quarter turn off on every template; its
turned pose is then a candidate the cross check can prefer.

The same costs are computed for every method, so the rule is the method's own only through its
estimates. The settings are those of the development runs that chose the rule
(docs/category-level.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: truncation of both Chamfer directions (object-normalised unit, ours' ``visibility_trunc``)
TRUNC = 0.1
#: ICP correspondence distance on another template (object-normalised unit)
ICP_DISTANCE = 0.03
#: ICP iterations on another template
ICP_ITERATIONS = 30
#: silhouette cell side (object-normalised unit at the view's median depth)
SILHOUETTE_CELL = 0.05
#: weight of ``1 - IoU`` of the silhouettes in each cost
SILHOUETTE_WEIGHT = 0.2
#: :func:`top_offset`: the fraction of a shape's points, highest along up, whose centroid is its top
TOP_FRACTION = 0.1
#: :func:`turn_candidates`: the turns about the template's up tried from each estimate (degrees;
#: chosen on the development chairs, docs/category-level.md)
TURNS_DEG = (90.0, 270.0)

_TARGETS: dict[str, tuple[Any, Any, np.ndarray, np.ndarray]] = {}


def _target(template: Any) -> tuple[Any, Any, np.ndarray, np.ndarray]:
    """(Open3D cloud with normals, cKDTree, points (M, 3), normals (M, 3)) of ``template``, cached
    by its id and size."""
    key = f"{template.template_id}#{len(template.points)}"
    if key not in _TARGETS:
        from scipy.spatial import cKDTree

        from catpose.o3d import o3d

        points, normals = np.asarray(template.points, float), np.asarray(template.normals, float)
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        pcd.normals = o3d.utility.Vector3dVector(normals)
        _TARGETS[key] = (pcd, cKDTree(points), points, normals)
    return _TARGETS[key]


def _cloud(points_camera: np.ndarray):
    """The view (N, 3) as an Open3D cloud."""
    from catpose.o3d import o3d

    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points_camera, float)))


def refine_on(
    points_camera: np.ndarray, template: Any, T_template_camera: np.ndarray, source: Any = None
) -> np.ndarray:
    """(4, 4) ``T_template_camera`` refined by point-to-plane ICP of ``points_camera`` (N, 3)
    against ``template`` (single-threaded: Open3D's parallel sums differ run to run); ``source``:
    the view already as an Open3D cloud (built here when None)."""
    from catpose.o3d import max_threads, o3d

    reg = o3d.pipelines.registration
    pcd = _target(template)[0]
    src = _cloud(points_camera) if source is None else source
    with max_threads(1):
        result = reg.registration_icp(
            src,
            pcd,
            ICP_DISTANCE,
            np.asarray(T_template_camera, float),
            reg.TransformationEstimationPointToPlane(),
            reg.ICPConvergenceCriteria(max_iteration=ICP_ITERATIONS),
        )
    return np.asarray(result.transformation).copy()


def silhouette_cells(points_camera: np.ndarray, cell: float) -> set[tuple[int, int]]:
    """The image cells (side ``cell`` in normalised image coordinates ``x / z``, ``y / z``) hit by
    ``points_camera`` (N, 3, camera frame); points at or behind the camera centre are left out."""
    P = np.asarray(points_camera, float)
    P = P[P[:, 2] > 1e-9]
    ij = np.floor(np.stack([P[:, 0] / P[:, 2], P[:, 1] / P[:, 2]], 1) / cell).astype(np.int64)
    return set(map(tuple, ij.tolist()))


def silhouette_iou(view_cells: set, template_points_camera: np.ndarray, cell: float) -> float:
    """Intersection over union of the view's silhouette cells and those of a posed template's
    points (M, 3, camera frame: every point, the outline of the whole shape is the outline of
    its visible side); 0 when either is empty."""
    cells = silhouette_cells(template_points_camera, cell)
    union = len(view_cells | cells)
    return len(view_cells & cells) / union if union else 0.0


def cross_costs(
    points_camera: np.ndarray, T_template_camera: np.ndarray, templates: Sequence[Any], own: int
) -> list[float]:
    """(K,) the cost of the estimate ``T_template_camera`` (4, 4) of the view ``points_camera``
    (N, 3, camera frame, object-normalised unit) on each of ``templates``; ``own`` is the index
    of the template it was estimated against (its cost is taken at the estimate unrefined)."""
    from catpose.geometry import invert_T, transform_points
    from catpose.methods.pose_scores import visibility_chamfer

    P = np.asarray(points_camera, float)
    T_est = np.asarray(T_template_camera, float)
    source = _cloud(P) if len(templates) > 1 else None  # one cloud for the K - 1 refinements
    cell = SILHOUETTE_CELL / float(np.median(P[:, 2]))  # the cell's side at the view's depth
    view_cells = silhouette_cells(P, cell)
    out = []
    # the ICPs start from the estimate rounded to 1e-9: its last bits differ between CPUs' BLAS
    # kernels, and an ICP can turn such a difference into another correspondence set
    T_start = np.round(T_est, 9)
    for j, template in enumerate(templates):
        T = T_est if j == own else refine_on(P, template, T_start, source)
        _, tree, points, normals = _target(template)
        iou = silhouette_iou(view_cells, transform_points(invert_T(T), points), cell)
        out.append(
            float(visibility_chamfer(P, T[None], points, normals, tree, TRUNC)[0]) + SILHOUETTE_WEIGHT * (1.0 - iou)
        )
    return out


def top_centroid(points_template: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(3,) the centroid of the highest ``TOP_FRACTION`` of ``points_template`` (N, 3) along the
    unit vector ``up`` (3,), less its component along ``up``: where the shape's top part stands
    in the plane across up (the points' unit)."""
    P = np.asarray(points_template, float)
    u = np.asarray(up, float) / np.linalg.norm(up)
    h = P @ u
    c = P[h >= np.quantile(h, 1.0 - TOP_FRACTION)].mean(axis=0)
    return c - (c @ u) * u


_TOPS: dict[str, np.ndarray] = {}


def _template_top(template: Any) -> np.ndarray:
    """:func:`top_centroid` of ``template``'s points along its ``up``, cached by id and size."""
    key = f"{template.template_id}#{len(template.points)}#{tuple(np.asarray(template.up, float))}"
    if key not in _TOPS:
        _TOPS[key] = top_centroid(template.points, template.up)
    return _TOPS[key]


def top_offset(points_camera: np.ndarray, T_template_camera: np.ndarray, templates: Sequence[Any], own: int) -> float:
    """Horizontal distance (object-normalised unit) between the top centroid of the view
    ``points_camera`` (N, 3, camera frame) posed by ``T_template_camera`` (4, 4, camera -> template
    ``own``) and the mean top centroid of ``templates`` (:func:`top_centroid`, along the own
    template's ``up``; the templates share one frame)."""
    from catpose.geometry import transform_points

    up = np.asarray(templates[own].up, float)
    view_top = top_centroid(
        transform_points(np.asarray(T_template_camera, float), np.asarray(points_camera, float)), up
    )
    category_top = np.mean([_template_top(t) for t in templates], axis=0)
    return float(np.linalg.norm(view_top - category_top))  # both already across up


def turned(T_template_camera: np.ndarray, up: np.ndarray, turn_deg: float) -> np.ndarray:
    """(4, 4) ``T_template_camera`` followed by a turn of ``turn_deg`` degrees about the unit
    vector ``up`` (3,) through the template frame's origin (right-handed)."""
    from scipy.spatial.transform import Rotation

    u = np.asarray(up, float) / np.linalg.norm(up)
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_rotvec(np.radians(float(turn_deg)) * u).as_matrix()
    return turn @ np.asarray(T_template_camera, float)


def turn_candidates(
    points_camera: np.ndarray,
    T_template_camera: np.ndarray,
    templates: Sequence[Any],
    own: int,
    turns_deg: Sequence[float] = TURNS_DEG,
) -> list[dict]:
    """For each turn of ``turns_deg``: the estimate ``T_template_camera`` (4, 4, camera -> template
    ``own``) :func:`turned` about the own template's ``up`` and refined on it (:func:`refine_on`),
    with its :func:`cross_costs` and :func:`top_offset`. Returns dicts ``turn_deg``,
    ``T_template_camera`` (4 x 4 nested lists), ``cross_costs`` (K,), ``top_offset``."""
    P = np.asarray(points_camera, float)
    up = np.asarray(templates[own].up, float)
    source = _cloud(P)
    out = []
    for deg in turns_deg:
        # from the estimate rounded to 1e-9, as in cross_costs: its last bits differ between kernels
        T = refine_on(P, templates[own], turned(np.round(np.asarray(T_template_camera, float), 9), up, deg), source)
        out.append(
            {
                "turn_deg": float(deg),
                "T_template_camera": T.tolist(),
                "cross_costs": cross_costs(P, T, templates, own),
                "top_offset": top_offset(P, T, templates, own),
            }
        )
    return out


def cross_cost(costs: Sequence[float], own: int, weight: float, top: float = 0.0, top_weight: float = 0.0) -> float:
    """One registration's ``cross`` cost from its :func:`cross_costs` row: its own template's cost
    plus ``weight`` times the mean of the other templates' (the own cost alone when K = 1), plus
    ``top_weight`` times its :func:`top_offset` ``top``."""
    c = np.asarray(costs, float)
    others = np.delete(c, own)
    return float(c[own] + (weight * others.mean() if len(others) else 0.0) + top_weight * float(top))
