"""How well one view's estimate fits each of its category's K templates: the facts the cross rules
of :mod:`catpose.methods.choice_rules` choose by (:class:`CrossCheck`).

The K templates share the category's canonical frame, so a right estimate from any template is a
pose the others also fit after a small correction; an estimate a quarter or half turn off fits its
own template by a shape coincidence the others do not share. For the estimate ``T`` (camera ->
template ``k``) of a view:

- the cost on template ``k`` is the visibility-aware Chamfer distance
  (:func:`catpose.methods.pose_scores.visibility_chamfer`, truncated at ``trunc``) at ``T``; on
  every other template the same after point-to-plane ICP from ``T`` (Open3D); each pays
  ``silhouette_weight x (1 - IoU)`` of the view's and the posed template's silhouettes
  (:func:`silhouette_iou`: a quarter-turned chair shows another outline even where Chamfer ties).
- :meth:`CrossCheck.top_offset`: where the view's top part stands (a chair's back, an airplane's fin).
- :meth:`CrossCheck.turn_candidates`: ``T`` turned about the template's up and refined (a chair's
  seat is often as wide as deep, so a registration can settle a quarter turn off on every template).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from catpose.content_hash import template_key
from catpose.methods import options

#: the defaults of :class:`CrossCheck`; configs/choice/score.yaml is the source (tests/test_choice_config.py)
TRUNC = 0.1
ICP_DISTANCE = 0.03
ICP_ITERATIONS = 30
SILHOUETTE_CELL = 0.05
SILHOUETTE_WEIGHT = 0.2
TOP_FRACTION = 0.1
#: the turns about the template's up tried from each estimate (degrees)
TURNS_DEG = (90.0, 270.0)

_TARGETS: dict[str, tuple[Any, Any, np.ndarray, np.ndarray]] = {}


def _target(template: Any) -> tuple[Any, Any, np.ndarray, np.ndarray]:
    """(Open3D cloud with normals, cKDTree, points (M, 3), normals (M, 3)) of ``template``, cached
    by its content (a template id names no seed: the same id holds other points under another)."""
    key = template_key(template)
    if key not in _TARGETS:
        from scipy.spatial import cKDTree

        from catpose.o3d import cloud

        points, normals = np.asarray(template.points, float), np.asarray(template.normals, float)
        _TARGETS[key] = (cloud(points, normals), cKDTree(points), points, normals)
    return _TARGETS[key]


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


def top_centroid(points_template: np.ndarray, up: np.ndarray, fraction: float = TOP_FRACTION) -> np.ndarray:
    """(3,) the centroid of the highest ``fraction`` of ``points_template`` (N, 3) along the
    unit vector ``up`` (3,), less its component along ``up``: where the shape's top part stands
    in the plane across up (the points' unit)."""
    P = np.asarray(points_template, float)
    u = np.asarray(up, float) / np.linalg.norm(up)
    h = P @ u
    c = P[h >= np.quantile(h, 1.0 - fraction)].mean(axis=0)
    return c - (c @ u) * u


_TOPS: dict[str, np.ndarray] = {}


def _template_top(template: Any, fraction: float) -> np.ndarray:
    """:func:`top_centroid` of ``template``'s points along its ``up``, cached by content, up and fraction."""
    key = f"{template_key(template)}#{tuple(np.asarray(template.up, float))}#{fraction!r}"
    if key not in _TOPS:
        _TOPS[key] = top_centroid(template.points, template.up, fraction)
    return _TOPS[key]


def turned(T_template_camera: np.ndarray, up: np.ndarray, turn_deg: float) -> np.ndarray:
    """(4, 4) ``T_template_camera`` followed by a turn of ``turn_deg`` degrees about the unit
    vector ``up`` (3,) through the template frame's origin (right-handed)."""
    from scipy.spatial.transform import Rotation

    u = np.asarray(up, float) / np.linalg.norm(up)
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_rotvec(np.radians(float(turn_deg)) * u).as_matrix()
    return turn @ np.asarray(T_template_camera, float)


class CrossCheck:
    """The cross check's costs, top offset and turned candidates of one estimate (module doc).

    Args:
        trunc: truncation of both Chamfer directions (object-normalised unit).
        icp_distance: ICP correspondence distance on another template (object-normalised unit).
        icp_iterations: ICP iterations on another template.
        silhouette_cell: silhouette cell side (object-normalised unit at the view's median depth).
        silhouette_weight: weight of ``1 - IoU`` of the silhouettes in each cost.
        top_fraction: the fraction of a shape's points, highest along up, whose centroid is its top.
    """

    def __init__(
        self,
        trunc: float = TRUNC,
        icp_distance: float = ICP_DISTANCE,
        icp_iterations: int = ICP_ITERATIONS,
        silhouette_cell: float = SILHOUETTE_CELL,
        silhouette_weight: float = SILHOUETTE_WEIGHT,
        top_fraction: float = TOP_FRACTION,
    ) -> None:
        self.trunc = options.positive("choice.cross_check.trunc", trunc)
        self.icp_distance = options.positive("choice.cross_check.icp_distance", icp_distance)
        self.icp_iterations = options.positive("choice.cross_check.icp_iterations", icp_iterations, integer=True)
        self.silhouette_cell = options.positive("choice.cross_check.silhouette_cell", silhouette_cell)
        self.silhouette_weight = options.non_negative("choice.cross_check.silhouette_weight", silhouette_weight)
        self.top_fraction = options.within("choice.cross_check.top_fraction", top_fraction, 0, 1, closed="high")

    def refine_on(
        self, points_camera: np.ndarray, template: Any, T_template_camera: np.ndarray, source: Any = None
    ) -> np.ndarray:
        """(4, 4) ``T_template_camera`` refined by point-to-plane ICP of ``points_camera`` (N, 3)
        against ``template`` (single-threaded: Open3D's parallel sums differ run to run); ``source``:
        the view already as an Open3D cloud (built here when None)."""
        from catpose.o3d import cloud, point_to_plane_icp

        src = cloud(points_camera) if source is None else source
        T = np.asarray(T_template_camera, float)
        return point_to_plane_icp(src, _target(template)[0], self.icp_distance, T, self.icp_iterations)

    def cross_costs(
        self, points_camera: np.ndarray, T_template_camera: np.ndarray, templates: Sequence[Any], own: int
    ) -> list[float]:
        """(K,) the cost of the estimate ``T_template_camera`` (4, 4) of the view ``points_camera``
        (N, 3, camera frame, object-normalised unit) on each of ``templates``; ``own`` is the index
        of the template it was estimated against (its cost is taken at the estimate unrefined)."""
        from catpose.geometry import invert_T, transform_points
        from catpose.methods.pose_scores import visibility_chamfer
        from catpose.o3d import cloud

        P = np.asarray(points_camera, float)
        T_est = np.asarray(T_template_camera, float)
        source = cloud(P) if len(templates) > 1 else None  # one cloud for the K - 1 refinements
        cell = self.silhouette_cell / float(np.median(P[:, 2]))  # the cell's side at the view's depth
        view_cells = silhouette_cells(P, cell)
        out = []
        # the ICPs start from the estimate rounded to 1e-9: its last bits differ between CPUs' BLAS
        # kernels, and an ICP can turn such a difference into another correspondence set
        T_start = np.round(T_est, 9)
        for j, template in enumerate(templates):
            T = T_est if j == own else self.refine_on(P, template, T_start, source)
            _, tree, points, normals = _target(template)
            iou = silhouette_iou(view_cells, transform_points(invert_T(T), points), cell)
            out.append(
                float(visibility_chamfer(P, T[None], points, normals, tree, self.trunc)[0])
                + self.silhouette_weight * (1.0 - iou)
            )
        return out

    def top_offset(
        self, points_camera: np.ndarray, T_template_camera: np.ndarray, templates: Sequence[Any], own: int
    ) -> float:
        """Horizontal distance (object-normalised unit) between the top centroid of the view
        ``points_camera`` (N, 3, camera frame) posed by ``T_template_camera`` (4, 4, camera -> template
        ``own``) and the mean top centroid of ``templates`` (:func:`top_centroid`, along the own
        template's ``up``; the templates share one frame)."""
        from catpose.geometry import transform_points

        up = np.asarray(templates[own].up, float)
        view_top = top_centroid(
            transform_points(np.asarray(T_template_camera, float), np.asarray(points_camera, float)),
            up,
            self.top_fraction,
        )
        category_top = np.mean([_template_top(t, self.top_fraction) for t in templates], axis=0)
        return float(np.linalg.norm(view_top - category_top))  # both already across up

    def turn_candidates(
        self,
        points_camera: np.ndarray,
        T_template_camera: np.ndarray,
        templates: Sequence[Any],
        own: int,
        turns_deg: Sequence[float] = TURNS_DEG,
    ) -> list[dict]:
        """For each turn of ``turns_deg`` (degrees): the estimate ``T_template_camera`` (4, 4, camera
        -> template ``own``) :func:`turned` about the own template's ``up`` and refined on it
        (:meth:`refine_on`), with its :meth:`cross_costs` and :meth:`top_offset`. Returns dicts
        ``turn_deg``, ``T_template_camera`` (4 x 4 nested lists), ``cross_costs`` (K,), ``top_offset``."""
        from catpose.o3d import cloud

        P = np.asarray(points_camera, float)
        up = np.asarray(templates[own].up, float)
        source = cloud(P)
        out = []
        for deg in turns_deg:
            # from the estimate rounded to 1e-9, as in cross_costs: its last bits differ between kernels
            T = self.refine_on(
                P, templates[own], turned(np.round(np.asarray(T_template_camera, float), 9), up, deg), source
            )
            out.append(
                {
                    "turn_deg": float(deg),
                    "T_template_camera": T.tolist(),
                    "cross_costs": self.cross_costs(P, T, templates, own),
                    "top_offset": self.top_offset(P, T, templates, own),
                }
            )
        return out
