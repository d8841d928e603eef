"""Open3D, imported safely.

Open3D's Linux wheels link against ``libusb-1.0.so.0``, which slim machines lack; the PyPI package
``libusb-package`` ships it, loaded before Open3D by :func:`catpose.open3d_libusb.preload_libusb`
(whatever the install did). Import Open3D only through this module::

    from catpose.o3d import o3d
"""

from __future__ import annotations

import contextlib

import numpy as np

from catpose.open3d_libusb import preload_libusb

preload_libusb()

import open3d as o3d  # noqa: E402

o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)


@contextlib.contextmanager
def max_threads(n: int | None):
    """Limit Open3D's worker threads inside the block (None: leave as is).

    Open3D's parallel reductions (ICP, RANSAC) sum in a scheduling-dependent order, so with more
    than one thread two runs can differ in the last digits and pick a different start or
    candidate; one thread makes them reproducible.
    """
    if n is None:
        yield
        return
    previous = o3d.utility.get_max_threads()
    o3d.utility.set_max_threads(int(n))
    try:
        yield
    finally:
        o3d.utility.set_max_threads(previous)


def cloud(points: np.ndarray, normals: np.ndarray | None = None):
    """An Open3D ``PointCloud`` of ``points`` (N, 3) and, when given, ``normals`` (N, 3), float64."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, dtype=np.float64)))
    if normals is not None:
        pcd.normals = o3d.utility.Vector3dVector(np.asarray(normals, dtype=np.float64))
    return pcd


def point_to_plane_icp(source, target, distance: float, T: np.ndarray, iterations: int) -> np.ndarray:
    """(4, 4) Open3D's point-to-plane ICP of the cloud ``source`` onto ``target`` (with normals)
    from ``T`` (4, 4), pairs within ``distance``, at most ``iterations``; on one thread (its
    parallel sums differ run to run)."""
    reg = o3d.pipelines.registration
    with max_threads(1):
        result = reg.registration_icp(
            source,
            target,
            distance,
            T,
            reg.TransformationEstimationPointToPlane(),
            reg.ICPConvergenceCriteria(max_iteration=iterations),
        )
    return np.asarray(result.transformation).copy()


__all__ = ["cloud", "max_threads", "o3d", "point_to_plane_icp"]
