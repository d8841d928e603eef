"""The segmenter-like mask corruption of development data (catpose.datasets.mask_noise)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from catpose.datasets.mask_noise import corrupt_mask


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """A 30 x 20 px object at 0.9 in front of a table at 2.1, a hole without depth beside it."""
    depth = np.full((80, 100), 2.1)
    depth[:, 70:] = 0.0  # no measurement
    mask = np.zeros((80, 100), dtype=bool)
    mask[25:55, 40:60] = True
    depth[mask] = 0.9
    return mask, depth


def test_strength_zero_is_the_mask_and_a_seed_fixes_the_corruption():
    mask, depth = _scene()
    np.testing.assert_array_equal(corrupt_mask(mask, depth, 0.0, 0, "f"), mask)
    a, b = corrupt_mask(mask, depth, 1.0, 3, "f"), corrupt_mask(mask, depth, 1.0, 3, "f")
    np.testing.assert_array_equal(a, b)
    draws = [corrupt_mask(mask, depth, 1.0, seed, "f") for seed in range(8)]
    assert len({d.tobytes() for d in draws}) > 1  # seeds differ
    assert len({corrupt_mask(mask, depth, 1.0, 0, f).tobytes() for f in "abcdefgh"}) > 1  # frames differ


def test_the_corruption_stays_near_the_edge_on_measured_pixels_and_never_empties():
    mask, depth = _scene()
    near = ndimage.binary_dilation(mask, np.ones((3, 3), bool), iterations=16)
    grew = 0
    for seed in range(20):
        out = corrupt_mask(mask, depth, 1.0, seed, "frame")
        added = out & ~mask
        assert out.any() and not (out & ~near).any()
        # blobs cover measured pixels only (an edge dilation of at most 3 px may reach the hole)
        assert not (added & (depth <= 0) & ~ndimage.binary_dilation(mask, np.ones((3, 3), bool), iterations=3)).any()
        grew += int((added & (depth > 2.0)).sum() > 0)  # table pixels metres behind the object
    assert grew >= 10
    tiny = np.zeros_like(mask)
    tiny[40, 50] = True
    assert all(corrupt_mask(tiny, depth, 1.0, s, "t").any() for s in range(10))
