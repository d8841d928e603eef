"""The plane fit's compiled inlier counts (``catpose.datasets.depthio.inlier_counts``) are NumPy's to the bit."""

from __future__ import annotations

import numpy as np

from catpose import kernel_threads
from catpose.datasets.depthio import inlier_counts
from catpose.geometry import dot3


def numpy_counts(p, normals, offsets, distance):
    """The NumPy expression the kernel replaced (``dot3``'s order, then the offset)."""
    return (np.abs(dot3(p[:, None, :], normals[None]) + offsets) < distance).sum(axis=0)


def test_counts_equal_numpys_on_a_noisy_table_with_points_on_the_threshold():
    rng = np.random.default_rng(0)
    table = np.c_[rng.uniform(-1, 1, (3000, 2)), rng.normal(0, 0.004, 3000)] + [0, 0, 2.0]
    clutter = rng.uniform(-1, 1, (1000, 3)) + [0, 0, 2.0]
    p = np.concatenate([table, clutter]) @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    idx = rng.integers(0, len(p), (300, 3))
    normals = np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    offsets = -dot3(normals, p[idx[:, 0]])
    distance = 0.01
    # points on the threshold of plane 0, to rounding (the comparison is strict)
    signed = dot3(p, normals[0]) + offsets[0]
    p[:5] -= (signed[:5] - distance)[:, None] * normals[0]
    expected = numpy_counts(p, normals, offsets, distance)
    assert expected.max() > 1000 and expected.min() >= 3  # the table planes and the three samples
    assert inlier_counts(p, normals, offsets, distance).tolist() == expected.tolist()


def test_counts_do_not_depend_on_the_threads():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(2000, 3))
    normals = rng.normal(size=(200, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    offsets = rng.normal(size=200) * 0.1
    before = kernel_threads.threads()
    try:
        kernel_threads.set_threads(1)
        one = inlier_counts(p, normals, offsets, 0.05)
        kernel_threads.set_threads(3)
        three = inlier_counts(p, normals, offsets, 0.05)
    finally:
        kernel_threads.set_threads(before)
    assert one.tolist() == three.tolist() == numpy_counts(p, normals, offsets, 0.05).tolist()
