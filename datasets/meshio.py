"""Mesh files (OFF, OBJ, PLY) and category templates built from them.

Reading: trimesh, for all three (``process=False`` keeps the vertices as written; polygons are
triangulated by trimesh). Its OFF reader takes ModelNet40's known quirk where the header keyword
and the counts share one line (``OFF490 518 0``), comments and Windows line endings.

Templates: a mesh file in its own axes (ShapeNet's ``model_normalized.obj`` is y-up, most CAD
files are z-up) is rotated so that its ``up`` axis becomes +z and its ``forward`` axis +x (the
template frame), normalised to the unit bounding sphere (centre at the bounding-box centre,
farthest vertex at distance 1), and sampled on its outer surface (points visible from outside,
so that inner faces of CAD models do not enter the cloud). A dataset's configured set of them:
:mod:`catpose.datasets.templates`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from catpose.errors import DatasetError
from catpose.geometry import apply_R, dot3, norm3, normalize_to_unit_sphere, stable_seed
from catpose.types import Template

_AXES = {"x": 0, "y": 1, "z": 2}
MESH_SUFFIXES = (".off", ".obj", ".ply")


# --------------------------------------------------------------------------- reading


def read_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read an OFF, OBJ or PLY triangle mesh with trimesh; returns vertices (V, 3) float64 and
    triangles (F, 3) int64, as written (``process=False``). A file that cannot be read, or holds
    no triangles, raises :class:`DatasetError` naming it."""
    return _read(Path(path))[1:]


def _read(path: Path) -> tuple[object, np.ndarray, np.ndarray]:
    """``(trimesh mesh, vertices, triangles)`` of a mesh file, checked as :func:`read_mesh` says."""
    import trimesh

    if not path.is_file():
        missing = "is a folder, not a file" if path.is_dir() else "does not exist"
        raise DatasetError(f"mesh file {path} {missing}; check the dataset root, the id or the path in the config")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise DatasetError(f"{path}: unsupported mesh format {suffix!r}; use .off, .obj or .ply")
    try:
        mesh = trimesh.load(str(path), file_type=suffix[1:], force="mesh", process=False, skip_materials=True)
    except Exception as exc:  # trimesh raises many types for a bad file
        why = " ".join(str(exc).split())[:80]
        raise DatasetError(
            f"{path} cannot be read as a mesh ({type(exc).__name__}: {why}); fix or re-export it"
        ) from None
    vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64)
    triangles = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    if not np.isfinite(vertices).all():
        raise DatasetError(f"{path} has non-finite vertex coordinates (NaN or inf); fix or re-export the mesh")
    if len(vertices) < 3 or len(triangles) == 0:
        raise DatasetError(f"{path} has no triangles ({len(vertices)} vertices, {len(triangles)} faces)")
    if triangles.min() < 0 or triangles.max() >= len(vertices):
        raise DatasetError(f"{path} has face indices outside 0..{len(vertices) - 1}")
    return mesh, vertices, triangles


def mesh_problem(path: Path) -> str | None:
    """Why the model file at ``path`` is not whole (``bench data check``), None when it is; never
    raises. :func:`read_mesh` must read it; a PLY must also hold every row its header's element
    counts promise (trimesh reads a short ASCII body without complaint), and an ASCII PLY must end
    with a newline (not cut inside its last line)."""
    try:
        mesh, data = _read(Path(path))[0], Path(path).read_bytes()
    except (DatasetError, OSError) as e:
        return f"{e}: download or unzip it again"
    rows = {name: (_rows(e.get("data", {})), e["length"]) for name, e in mesh.metadata.get("_ply_raw", {}).items()}
    short = [f"{have} {name} rows of {want}" for name, (have, want) in rows.items() if have < want]
    if data.startswith(b"ply") and b"format ascii" in data[:40] and not data.endswith(b"\n"):
        short.append("its last line is cut")
    if short:
        return f"{path} is not a whole PLY model ({', '.join(short)}): cut off; download or unzip it again"
    return None


def _rows(data: np.ndarray | dict) -> int:
    """Rows of one element of trimesh's raw PLY (a structured array, or a dict of columns)."""
    return len(data) if isinstance(data, np.ndarray) else len(next(iter(data.values()), ()))


# --------------------------------------------------------------------------- axes


def axis_vector(spec: str) -> np.ndarray:
    """``"+y"``, ``"-z"``, ``"x"`` -> the unit vector (3,)."""
    s = str(spec).strip().lower()
    sign = -1.0 if s.startswith("-") else 1.0
    s = s.lstrip("+-")
    if s not in _AXES:
        raise DatasetError(f"axis {spec!r} is not one of +x, -x, +y, -y, +z, -z")
    v = np.zeros(3)
    v[_AXES[s]] = sign
    return v


def R_template_file(up: str = "+z", forward: str = "+x") -> np.ndarray:
    """Rotation (3, 3) taking a file's axes to the template frame: ``up`` -> +z, ``forward`` -> +x."""
    u, f = axis_vector(up), axis_vector(forward)
    if abs(dot3(u, f)) > 0.5:
        raise DatasetError(f"up {up!r} and forward {forward!r} must be different axes")
    # rows are the file-frame directions of the template axes x, y, z
    return np.stack([f, np.cross(u, f), u])


# --------------------------------------------------------------------------- sampling


def fibonacci_sphere(n: int, radius: float = 1.0) -> np.ndarray:
    """(n, 3) points spread near-uniformly on a sphere of ``radius`` (golden-angle spiral)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return radius * np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def sample_outer_surface(
    vertices: np.ndarray,
    triangles: np.ndarray,
    n_points: int,
    seed: int | np.random.Generator,
    n_views: int = 40,
    view_distance: float = 3.0,
    oversample: int = 4,
) -> tuple[np.ndarray, np.ndarray]:
    """Uniform samples of the part of a mesh's surface seen from outside, with outward normals.

    Works for meshes made of concatenated parts with interior faces: draws
    ``oversample * n_points`` area-weighted surface samples, keeps those that are the first hit
    of a ray from at least one of ``n_views`` viewpoints on a sphere of radius
    ``view_distance * r`` around the origin (``r``: the farthest vertex's distance from the
    origin, 1 for a unit-sphere normalised mesh), and draws ``n_points`` of them without
    replacement (with replacement only when fewer are visible).

    Args:
        vertices: (V, 3) mesh vertices, object frame; the origin should lie inside the object
            (e.g. a unit-sphere normalised mesh).
        triangles: (F, 3) faces.
        n_points: number of points to return.
        seed: an int seed or a seeded generator; the result is a pure function of it and the mesh.
        n_views: number of viewpoints (golden-angle spiral).
        view_distance: viewpoint distance from the origin in units of ``r``.
        oversample: candidates per returned point.

    Returns:
        (n_points, 3) points and (n_points, 3) unit normals, both in the mesh frame; normals are
        the face normals oriented towards the most frontal viewpoint that sees the point
        (outward).

    Raises:
        DatasetError: the mesh has only zero-area faces, or fewer than 10 samples are visible.
    """
    from catpose.raycast import RayCaster

    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    n_cand = oversample * n_points
    tri = vertices[triangles]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    if not (area2 > 1e-15).any():
        raise DatasetError("mesh has only zero-area triangles; it cannot be sampled")
    face = rng.choice(len(triangles), size=n_cand, p=area2 / area2.sum())
    u, v = rng.random(n_cand), rng.random(n_cand)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tri[face]
    points = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    normals = cross[face] / np.maximum(area2[face], 1e-20)[:, None]

    r = max(float(norm3(vertices).max()), 1e-9)
    eyes = fibonacci_sphere(n_views, view_distance * r)
    # one ray per (viewpoint, sample), cast in a single batch; the unnormalised direction
    # (sample - eye) puts the sample itself at t_hit == 1 (float64, the same on every CPU)
    origins = np.repeat(eyes, n_cand, axis=0)
    d = np.tile(points, (n_views, 1)) - origins
    t_hit = RayCaster(vertices, triangles).cast(origins, d).reshape(n_views, n_cand)
    tol = 1e-3 * r / norm3(d).reshape(n_views, n_cand)  # 1e-3 r (object units)
    visible = t_hit >= 1.0 - tol
    keep = np.nonzero(visible.any(axis=0))[0]
    if len(keep) < 10:
        raise DatasetError("mesh surface is not visible from outside (fewer than 10 visible samples)")
    if len(keep) != n_points:
        keep = np.sort(rng.choice(keep, size=n_points, replace=len(keep) < n_points))
    points, normals = points[keep], normals[keep]
    # orient each normal towards the most frontal viewpoint that sees its sample (a sample on a
    # face's border may also be grazed from behind the face)
    to_eye = eyes[:, None, :] - points[None]  # (views, M, 3)
    cos = np.einsum("vmk,mk->vm", to_eye, normals) / np.linalg.norm(to_eye, axis=2)
    best = np.argmax(np.where(visible[:, keep], np.abs(cos), -1.0), axis=0)
    normals[cos[best, np.arange(len(keep))] < 0] *= -1
    return points, normals


# --------------------------------------------------------------------------- templates


def mesh_to_template(
    vertices: np.ndarray,
    triangles: np.ndarray,
    template_id: str,
    category: str,
    n_points: int = 2048,
    seed: int = 0,
    up: str = "+z",
    forward: str = "+x",
    scale: float = 1.0,
    symmetry_axis: np.ndarray | None = None,
) -> Template:
    """Rotate a mesh into the template frame, normalise it and sample its outer surface.

    Args:
        vertices: (V, 3) in the file's axes and units.
        triangles: (F, 3).
        n_points: number of surface samples.
        seed: sampling seed (combined with ``template_id``).
        up, forward: the file's axes that become +z and +x.
        scale: multiplies the vertices before normalisation (centre at the bounding-box centre,
            scaled to the unit bounding sphere).
    """
    v = apply_R(R_template_file(up, forward), np.asarray(vertices, np.float64) * float(scale))
    try:
        v, _, _ = normalize_to_unit_sphere(v)
    except ValueError:
        raise DatasetError(f"template {template_id}: mesh has zero extent") from None
    return sampled_template(v, triangles, template_id, category, n_points, seed, symmetry_axis)


def sampled_template(
    vertices: np.ndarray,
    triangles: np.ndarray,
    template_id: str,
    category: str,
    n_points: int = 2048,
    seed: int = 0,
    symmetry_axis: np.ndarray | None = None,
) -> Template:
    """A template (mesh plus outer-surface samples) of a mesh already in the template frame.

    Args:
        vertices: (V, 3) template frame (z up, x forward), unit-sphere normalised.
        triangles: (F, 3).
        n_points: number of surface samples (:func:`sample_outer_surface`).
        seed: sampling seed, combined with ``template_id`` so each template has its own stream.
        symmetry_axis: (3,) main axis in the template frame for symmetric objects, or None.
    """
    pts, nrm = sample_outer_surface(vertices, triangles, n_points, stable_seed(seed, template_id))
    axis = None if symmetry_axis is None else np.asarray(symmetry_axis, np.float64)
    return Template(
        template_id=template_id,
        category=category,
        points=pts,
        normals=nrm,
        vertices=vertices,
        triangles=np.asarray(triangles, np.int64),
        symmetry_axis=axis,
    )
