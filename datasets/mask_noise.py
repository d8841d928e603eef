"""The masks a segmenter gives, for development data: a clean object mask corrupted the way real
masks are (issue 58: the real YCB-Video masks of unseen scenes hold background pixels metres behind
the object, over 5 % of a small can's pixels).

:func:`corrupt_mask` draws a strength ``s`` uniformly in ``[0, strength]`` per instance and then

- moves the edge: the mask dilated or eroded (even odds) by ``round(3 s)`` pixels;
- bleeds: ``Poisson(4 s)`` blobs, each a disc of radius ``2 + 10 s`` pixels at most, centred on a
  pixel just outside the mask, join the mask where they cover measured pixels that are not the
  object's: the table behind it, or a neighbour.

Everything is drawn from a generator seeded by ``(seed, frame id)``, so a run's masks are fixed by
its seed. A pure function of the mask and the depth image: any loader can call it on its frames
(``dataset=clutter``'s ``mask_noise`` key does).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from catpose.geometry import stable_seed

__all__ = ["corrupt_mask"]

_SQUARE = np.ones((3, 3), dtype=bool)


def corrupt_mask(mask: np.ndarray, depth: np.ndarray, strength: float, seed: int, frame_id: str) -> np.ndarray:
    """``mask`` (H, W) bool corrupted as in the module docstring; ``depth`` (H, W), 0 where not
    measured (added pixels need a measurement); ``strength`` in [0, 1] (0: ``mask`` unchanged).
    Never returns an empty mask (an erosion that would empty it is skipped). A new array."""
    mask = np.asarray(mask, dtype=bool)
    if strength <= 0 or not mask.any():
        return mask.copy()
    rng = np.random.default_rng(stable_seed("mask-noise", seed, frame_id))
    s = float(rng.uniform(0.0, strength))
    out = mask.copy()
    r = int(round(3.0 * s))
    if r > 0:
        if rng.random() < 0.5:
            out = ndimage.binary_dilation(out, _SQUARE, iterations=r)
        else:
            eroded = ndimage.binary_erosion(out, _SQUARE, iterations=r)
            out = eroded if eroded.any() else out
    measured = np.asarray(depth) > 0
    ring = np.argwhere(ndimage.binary_dilation(mask, _SQUARE) & ~mask)
    n_blobs = int(rng.poisson(4.0 * s)) if len(ring) else 0
    h, w = mask.shape
    yy, xx = np.mgrid[0:h, 0:w]
    for _ in range(n_blobs):
        cy, cx = ring[int(rng.integers(len(ring)))]
        radius = float(rng.uniform(1.0, 2.0 + 10.0 * s))
        y0, y1, x0, x1 = (
            max(cy - int(radius) - 1, 0),
            cy + int(radius) + 2,
            max(cx - int(radius) - 1, 0),
            cx + int(radius) + 2,
        )
        disc = (yy[y0:y1, x0:x1] - cy) ** 2 + (xx[y0:y1, x0:x1] - cx) ** 2 <= radius * radius
        out[y0:y1, x0:x1] |= disc & measured[y0:y1, x0:x1] & ~mask[y0:y1, x0:x1]
    return out
