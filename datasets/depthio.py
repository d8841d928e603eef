"""Depth frames from files and the ground plane under an object: what every real RGB-D loader
(BOP, Redwood) shares; whether a PNG is whole (``bench data check``); and camera trajectories in
the Redwood / Open3D ``.log`` format.

Depth PNGs are uint16 in the sensor's unit (millimetres times a scale the loader knows); TIFF
depth (ITODD) is float. The ground normal of a real frame is the normal of the dominant plane of
the background depth, found by seeded RANSAC (as Open3D's ``segment_plane``): the paper's
gravity direction.
"""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np

from catpose import kernel_threads
from catpose.errors import DatasetError
from catpose.geometry import dot3, smallest_eigenvector_sym3

REFETCH = "download or unzip it again"
PNG_END = b"\0\0\0\0IEND\xaeB`\x82"  # the IEND chunk: a PNG's last 12 bytes (Pillow's verify stops before its CRC)


def _image(path: Path, what: str) -> np.ndarray:
    """The image at ``path`` (Pillow) as an array; a missing or unreadable file raises
    :class:`DatasetError` naming it."""
    from PIL import Image

    if not path.is_file():
        raise DatasetError(f"{what} {path} does not exist")
    try:
        with Image.open(path) as im:
            return np.asarray(im)
    except Exception as exc:  # PIL raises several types for a broken file
        raise DatasetError(f"{what} {path} cannot be read as an image ({type(exc).__name__}); {REFETCH}") from None


def read_depth(path: Path) -> np.ndarray:
    """A depth image (16-bit PNG, or TIFF as in ITODD) as a (H, W) array of raw values (multiply
    by the frame's ``depth_scale`` for mm); a PNG is uint16, other PNG dtypes raise
    :class:`DatasetError`."""
    arr = _image(path, "depth image")
    png = path.suffix.lower() == ".png"
    if arr.ndim != 2 or arr.dtype.kind not in "uif" or png and arr.dtype not in (np.uint16, np.int32, np.int16):
        kind = "16-bit PNG" if png else "image"
        raise DatasetError(f"{path} is {arr.dtype} with shape {arr.shape}; depth must be a single-channel {kind}")
    if png and arr.dtype != np.uint16:  # PIL opens some 16-bit PNGs as mode "I" (int32)
        if arr.min() < 0 or arr.max() > 65535:
            raise DatasetError(f"{path} has values outside 0..65535; depth must be a 16-bit PNG")
        arr = arr.astype(np.uint16)
    return arr


def read_mask_png(path: Path) -> np.ndarray:
    """A mask PNG as a (H, W) bool array (non-zero = object)."""
    arr = _image(path, "mask")
    return (arr if arr.ndim == 2 else arr[..., 0]) > 0


def png_problem(path: Path, size: tuple[int, int] | None = None, depth16: bool = False) -> str | None:
    """Why the file at ``path`` is not a whole PNG (Pillow's ``verify``: every chunk's length and
    CRC up to ``IEND``, nothing decoded), or, with ``depth16``, not a 16-bit single-channel depth
    image, or, with ``size``, not ``(width, height)``; None when it is. Never raises."""
    from PIL import Image

    try:
        with Image.open(path, formats=["PNG"]) as im:
            mode, im_size = im.mode, im.size
            im.verify()
        with open(path, "rb") as fh:
            fh.seek(-len(PNG_END), 2)
            if fh.read() != PNG_END:
                raise SyntaxError("it does not end with the IEND chunk (cut off)")
    except Exception as exc:  # PIL raises several types for a cut-off or damaged file
        why = " ".join(str(exc).split())[:80]
        return f"{path} is not a whole PNG ({type(exc).__name__}: {why}); {REFETCH}"
    if depth16 and mode not in ("I;16", "I;16B", "I"):
        return f"{path} is a PNG of mode {mode}; a depth image is a 16-bit single-channel PNG"
    if size is not None and im_size != tuple(size):
        return f"{path} is {im_size[0]}x{im_size[1]}, not {size[0]}x{size[1]} as the other images of the dataset"
    return None


def png_size(path: Path) -> tuple[int, int] | None:
    """``(width, height)`` of a PNG from its header, None when it has none."""
    from PIL import Image

    try:
        with Image.open(path, formats=["PNG"]) as im:
            return im.size
    except Exception:  # not a PNG, or unreadable
        return None


def fit_ground_plane(points: np.ndarray, distance: float, iterations: int, seed: int) -> tuple[np.ndarray, float, int]:
    """Dominant plane ``n . p + d = 0`` of ``points`` (N, 3) by RANSAC, refined by least squares.

    The same three-point RANSAC as Open3D's ``segment_plane``, but run here with a seeded NumPy
    generator: Open3D's multithreaded version returns slightly different planes from run to run,
    and observations must be deterministic functions of (seed, id). The best plane's inliers are
    then refitted by least squares (smallest principal axis).

    Returns the unit normal ``n`` (3,) oriented towards the origin (the camera), the offset
    ``d`` >= 0 (so ``n . p + d`` is the height above the plane) and the number of inliers.
    ``distance`` is in the points' unit.
    """
    p = np.asarray(points, np.float64)
    if len(p) < 3:
        raise DatasetError("too few background points to fit the ground plane")
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(p), size=(max(int(iterations), 1), 3))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    normals = np.cross(b - a, c - a)
    norms = np.linalg.norm(normals, axis=1)
    ok = norms > 1e-12 * max(float(np.abs(p).max()), 1.0) ** 2
    if not ok.any():
        raise DatasetError("background points are collinear; cannot fit the ground plane")
    normals, offsets = normals[ok] / norms[ok, None], -np.einsum("ij,ij->i", normals[ok] / norms[ok, None], a[ok])
    best = int(inlier_counts(p, normals, offsets, distance).argmax())  # the first of the most inliers
    n, d = normals[best], offsets[best]
    for _ in range(2):  # least-squares refinement on the inliers
        inl = p[np.abs(dot3(p, n) + d) < distance]
        if len(inl) < 3:
            break
        centroid = inl.mean(axis=0)
        X = inl - centroid
        n_new = smallest_eigenvector_sym3(np.einsum("ni,nj->ij", X, X))  # closed form, not LAPACK
        n = n_new if dot3(n_new, n) >= 0 else -n_new
        d = -dot3(n, centroid)
    n_inliers = int((np.abs(dot3(p, n) + d) < distance).sum())
    if d < 0:  # the origin must lie on the positive side: n . 0 + d > 0
        n, d = -n, -d
    return n, float(d), n_inliers


@numba.njit(cache=True, nogil=True)
def _counts(p, normals, offsets, distance, lo, hi, out):  # pragma: no cover - compiled
    """``out[h]`` for planes ``lo <= h < hi``: points of ``p`` (N, 3) within ``distance``."""
    n_points = p.shape[0]
    for h in range(lo, hi):
        nx, ny, nz, d = normals[h, 0], normals[h, 1], normals[h, 2], offsets[h]
        c = 0
        for i in range(n_points):
            if abs(p[i, 0] * nx + p[i, 1] * ny + p[i, 2] * nz + d) < distance:
                c += 1
        out[h] = c


def inlier_counts(points: np.ndarray, normals: np.ndarray, offsets: np.ndarray, distance: float) -> np.ndarray:
    """(H,) int64: for each plane ``normals[h] . p + offsets[h] = 0`` (``normals`` (H, 3) unit,
    ``offsets`` (H,)), how many of ``points`` (N, 3) lie strictly within ``distance`` of it (the
    points' unit).

    Compiled (numba): one pass over the points per range of planes instead of NumPy temporaries of
    (points x planes). Each count is the NumPy expression it replaced, to the bit: the signed
    distance is ``((p_x n_x + p_y n_y) + p_z n_z) + d`` in float64 without fused multiply-adds
    (:func:`catpose.geometry.dot3`'s order); ``tests/test_depthio.py`` checks it. Ranges of planes
    go to the run's ``threads`` (:func:`catpose.kernel_threads.split`), one plane per thread, so
    the counts do not depend on the number of threads."""
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.ascontiguousarray(normals, dtype=np.float64).reshape(-1, 3)
    d = np.ascontiguousarray(offsets, dtype=np.float64).reshape(-1)
    out = np.zeros(len(n), dtype=np.int64)
    kernel_threads.split(lambda lo, hi: _counts(p, n, d, float(distance), lo, hi, out), len(n))
    return out


def read_log_trajectory(path: str | Path) -> dict[int, np.ndarray]:
    """Read a Redwood / Open3D ``.log`` trajectory: ``{frame index: T_world_camera (4, 4)}``."""
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"trajectory {path} does not exist")
    lines = [ln.split() for ln in path.read_text().splitlines() if ln.strip()]
    if len(lines) % 5:
        raise DatasetError(
            f"{path} is malformed: {len(lines)} non-empty lines is not a multiple of 5 "
            "(a metadata line and 4 matrix rows per frame)"
        )
    poses: dict[int, np.ndarray] = {}
    for k in range(0, len(lines), 5):
        try:
            frame = int(lines[k][0])
            T = np.array([[float(x) for x in row] for row in lines[k + 1 : k + 5]])
        except (ValueError, IndexError):
            raise DatasetError(
                f"{path} is malformed near line {k + 1}: expected 'i j n' and 4 rows of 4 numbers"
            ) from None
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise DatasetError(f"{path} line {k + 2}: the pose is not 4 rows of 4 finite numbers")
        poses[frame] = T
    return poses
