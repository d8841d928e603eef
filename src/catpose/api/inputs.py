"""The inputs of :func:`catpose.register`: argument checks (one-line errors naming the argument),
the template as the methods' normalised :class:`~catpose.types.Template`, the observation's normals.

Normalisation: the template is rotated so that its up axis is +z (``R_up``), centred at its
bounding-box centre ``c`` and divided by its radius ``s`` (the farthest point's distance from
``c``): ``p_normalised = (R_up p - c) / s``, the object-normalised unit every method works in.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from catpose.errors import CatposeError, InvalidInputError
from catpose.geometry import R_onto_z, apply_R, dot3, matmul3, norm3, normalize_to_unit_sphere, stable_seed, unit3
from catpose.types import Template, points_arg

__all__ = [
    "MAX_TEMPLATE_POINTS",
    "NormalisedTemplate",
    "check_position",
    "direction_arg",
    "estimated_normals",
    "normalised_template",
    "normals_arg",
    "oriented_to_camera",
    "unit_warning",
]

#: the most points ``template_points`` may ask for: a mesh is sampled 4x over and each sample
#: ray-cast from 40 views (16 M rays here, seconds; the methods use 2048)
MAX_TEMPLATE_POINTS = 100_000


@dataclass(frozen=True, eq=False)
class NormalisedTemplate:
    """A template as the methods see it and the map back to the caller's frame and unit.

    ``p_normalised = (R_up p - centre) / scale`` for a point ``p`` of the caller's template frame.

    Attributes:
        template: the :class:`~catpose.types.Template` in the object-normalised frame and unit
            (up axis +z, unit bounding sphere).
        R_up: (3, 3) turns the caller's template frame into the normalised one (``template_up``
            onto +z; the BOP loader's model axes).
        centre: (3,) the template's centre after ``R_up``, caller's unit.
        scale: the template's radius, caller's unit (one object-normalised unit).
    """

    template: Template
    R_up: np.ndarray
    centre: np.ndarray
    scale: float

    def __post_init__(self) -> None:
        if not isinstance(self.template, Template):
            raise InvalidInputError(f"NormalisedTemplate.template is a {type(self.template).__name__}, not a Template")
        R = np.asarray(self.R_up, dtype=np.float64).reshape(3, 3)
        if np.abs(matmul3(R, R.T) - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
            raise InvalidInputError("NormalisedTemplate.R_up is not a rotation")
        scale = float(self.scale)
        if not (np.isfinite(scale) and scale > 0):
            raise InvalidInputError(f"NormalisedTemplate.scale={self.scale!r} must be a positive length")
        object.__setattr__(self, "R_up", R)
        object.__setattr__(self, "centre", np.asarray(self.centre, dtype=np.float64).reshape(3))
        object.__setattr__(self, "scale", scale)


def normals_arg(name: str, value: Any, points: np.ndarray) -> np.ndarray | None:
    """Unit normals (N, 3) matching ``points`` (N, 3), None for None, or a one-line error."""
    if value is None:
        return None
    n = points_arg(name, value, min_points=0)
    if n.shape != points.shape:
        raise InvalidInputError(f"{name} has shape {n.shape}; expected {points.shape} (one normal per point)")
    length = norm3(n)
    if (length < 1e-12).any():
        raise InvalidInputError(
            f"{name} has {int((length < 1e-12).sum())} zero-length normals; pass None to estimate them"
        )
    return n / length[:, None]


def direction_arg(name: str, value: Any) -> np.ndarray:
    """A unit 3-vector (3,) from ``value``, or a one-line error naming the argument."""
    try:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r} is not a 3-vector of numbers") from None
    if v.shape != (3,) or not np.isfinite(v).all() or norm3(v) < 1e-12:
        raise InvalidInputError(f"{name}={value!r} is not a finite non-zero 3-vector")
    return unit3(v)


def _template_geometry(template: Any) -> tuple[np.ndarray, np.ndarray | None]:
    """``(points or vertices (M, 3), triangles (F, 3) or None)`` of any accepted template form."""
    if isinstance(template, (str, Path)):
        from catpose.datasets.meshio import read_mesh

        if not Path(template).is_file():
            raise InvalidInputError(
                f"template: mesh file {template} does not exist; pass an existing .off, .obj or "
                ".ply file, a mesh or an (M, 3) array"
            )
        try:
            return read_mesh(template)
        except CatposeError as e:
            raise InvalidInputError(f"template: {e}") from None
    if hasattr(template, "vertices") and hasattr(template, "faces"):  # a trimesh.Trimesh (or alike)
        v, f = np.asarray(template.vertices), np.asarray(template.faces)
        if f.size == 0:
            return points_arg("template vertices", v), None
        return points_arg("template vertices", v, 3), _triangles(f, len(v))
    if (
        isinstance(template, (tuple, list))
        and len(template) == 2
        and np.ndim(template[1]) == 2
        and np.shape(template[1])[-1] == 3
        and np.ndim(template[0]) == 2
    ):
        v = points_arg("template vertices", template[0], 3)
        return v, _triangles(template[1], len(v))
    return points_arg("template", template), None


def _triangles(faces: Any, n_vertices: int) -> np.ndarray:
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer):
        raise InvalidInputError(f"template faces have shape {f.shape} and dtype {f.dtype}; expected (F, 3) integers")
    if f.min() < 0 or f.max() >= n_vertices:
        raise InvalidInputError(f"template faces index vertices outside 0..{n_vertices - 1}")
    return f.astype(np.int64)


def normalised_template(
    template: Any, template_normals: Any, template_up: np.ndarray, template_points: int
) -> NormalisedTemplate:
    """The template in the object-normalised frame and unit, with the map back
    (:class:`NormalisedTemplate`); a :class:`NormalisedTemplate` is returned as it is (then
    ``template_normals`` must be None).

    Raises:
        InvalidInputError: one line naming the argument (no file, degenerate, too many points).
    """
    if isinstance(template, NormalisedTemplate):
        if template_normals is not None:
            raise InvalidInputError("template_normals applies to a cloud template, not to a NormalisedTemplate")
        return template
    if template_points > MAX_TEMPLATE_POINTS:
        raise InvalidInputError(
            f"template_points={template_points} is more than {MAX_TEMPLATE_POINTS}; the methods use 2048 "
            "(more only costs time and memory)"
        )
    try:
        return _normalised_template(template, template_normals, template_up, template_points)
    except MemoryError:
        raise InvalidInputError(
            f"template: out of memory preparing it with template_points={template_points}; "
            "pass a smaller mesh or cloud, or fewer template_points"
        ) from None


def _normalised_template(
    template: Any, template_normals: Any, template_up: np.ndarray, template_points: int
) -> NormalisedTemplate:
    from catpose.datasets.meshio import sampled_template
    from catpose.datasets.render import estimate_normals
    from catpose.datasets.views import subsample

    geometry, triangles = _template_geometry(template)
    normals = None if triangles is not None else normals_arg("template_normals", template_normals, geometry)
    if triangles is not None and template_normals is not None:
        raise InvalidInputError(
            "template_normals applies to a point-cloud template; a mesh's normals come "
            "from its faces: drop template_normals"
        )
    R_up = R_onto_z(template_up)
    rotated = apply_R(R_up, geometry)
    check_position("template", rotated)
    try:
        points, centre, scale = normalize_to_unit_sphere(rotated)
    except ValueError:
        raise InvalidInputError("template has zero extent (all points equal)") from None
    extent = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if extent[1] <= 1e-9 * np.sqrt(len(points)):
        raise InvalidInputError("template is degenerate: all points lie on one line")
    if triangles is not None:
        try:
            t = sampled_template(points, triangles, "catpose.register/template", "object", template_points)
        except CatposeError as e:
            raise InvalidInputError(f"template: {e}") from None
        return NormalisedTemplate(t, R_up, centre, scale)
    if normals is None:  # as the datasets do: local planes, radius 0.1 object unit, here oriented outwards
        normals = estimate_normals(points, 0.1, viewpoint=np.zeros(3))
        normals = -normals  # estimate_normals faces the viewpoint (the centre): outwards is the opposite
    else:
        normals = apply_R(R_up, normals)
    rng = np.random.default_rng(stable_seed("catpose.register", "template"))
    points, normals = subsample(template_points, rng, points, normals)
    try:
        t = Template(template_id="catpose.register/template", category="object", points=points, normals=normals)
    except CatposeError as e:
        raise InvalidInputError(f"template: {e}") from None
    return NormalisedTemplate(t, R_up, centre, scale)


def seen_by_a_camera(points: np.ndarray) -> bool:
    """Whether a camera at the origin looking along +z can have seen ``points`` (N, 3): every
    point in front of it. A cloud around the origin (a complete scan, or the template itself
    passed as the observation: issue 42, case 19) was not, and "towards the camera" would turn
    its normals inwards, against the template's outward ones (FPFH and PPF compare them)."""
    return bool((points[:, 2] > 0).all())


def _facing(points: np.ndarray) -> np.ndarray:
    """(N, 3) the directions normals should face: towards the camera at the origin, or, for a
    cloud no camera saw, away from its bounding-box centre (outwards, as a template's)."""
    if seen_by_a_camera(points):
        return -points
    return points - 0.5 * (points.min(axis=0) + points.max(axis=0))


def estimated_normals(points: np.ndarray) -> np.ndarray:
    """Normals (N, 3) of camera-frame points (N, 3, object-normalised unit) by local plane fits of
    radius 0.1, facing the camera, as the datasets estimate them (outwards for a cloud no camera
    saw, :func:`seen_by_a_camera`)."""
    from catpose.datasets.render import estimate_normals

    if seen_by_a_camera(points):
        return estimate_normals(points, 0.1)
    return oriented_to_camera(points, estimate_normals(points, 0.1))


def oriented_to_camera(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``normals`` (N, 3) flipped where they face away from the camera at the origin; for a cloud
    no camera saw (:func:`seen_by_a_camera`), where they face its bounding-box centre."""
    flip = dot3(normals, _facing(points)) < 0
    out = normals.copy()
    out[flip] *= -1
    return out


def check_position(name: str, points: np.ndarray) -> None:
    """Refuse a cloud (N, 3) whose extent is below float64's resolution at its distance from the
    origin (coordinates at 1e12 for an object of size 1): its points are not all equal, but every
    check and method would see them so. One line naming ``name``."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    extent = float(norm3(hi - lo))
    distance = float(np.abs(points).max())
    if extent == 0:
        raise InvalidInputError(f"{name} has zero extent (all {len(points)} points equal)")
    if not np.isfinite(extent):
        raise InvalidInputError(f"{name} spans more than float64 holds; pass coordinates in a smaller unit")
    if extent < 1e-9 * distance:
        raise InvalidInputError(
            f"{name} spans {extent:.3g} but lies {distance:.3g} from the origin, beyond float64's resolution "
            "there; pass coordinates near the origin (an observation in the camera frame, the camera at the origin)"
        )


def unit_warning(radius: float, what: str = "observation") -> str | None:
    """The warning for an observation whose radius (bounding-box half diagonal) is ``radius``
    template radii, when that says the two are in different units (or the observation is not only
    the object); None when it looks right. A partial view spans about 0.3 to 1.2 template radii."""
    spans = f"catpose.register: the {what} span{'s' if what == 'observation' else ''}"
    if radius > 2.0:
        return (
            f"{spans} {radius:.1f} template radii; check that both use the same unit and that the observation "
            "holds only the object (a mask's stray pixels: ours' depth check copes with a few)"
        )
    if 0 < radius < 0.1:
        return (
            f"{spans} {radius:.3g} template radii, {1.0 / radius:.3g} times smaller than the template: are they "
            "in different units (metres against millimetres: 1000)? pass both in one unit (a DepthFrame: set depth_scale)"
        )
    return None
