"""A depth frame as input: a scene's depth image, its camera matrix and the object's mask.

:class:`DepthFrame` is what ``catpose.register`` takes from an RGB-D camera and what the BOP
loader (:mod:`catpose.datasets.bop`) builds for every instance of a ``bench run``; both
turn it into a registration problem with one function
(:func:`catpose.datasets.frame_view.frame_view`). Its arguments are checked here, once, at the
boundary: a bad one raises :class:`~catpose.errors.InvalidInputError` in one line that names the
argument and the fix.

Units and frames: ``depth`` times ``depth_scale`` is the camera-frame z of each pixel in the
template's unit (a BOP frame: uint16 counts times the ``depth_scale`` of ``scene_camera.json``,
millimetres); 0 or a non-finite value is a pixel without a measurement. ``K`` is the pinhole matrix
in pixels, OpenCV's convention: pixel (row, col) sees the ray ``((col - cx) / fx, (row - cy) / fy, 1)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from catpose.errors import InvalidInputError

__all__ = ["DepthFrame", "scaled_depth"]


def scaled_depth(depth: np.ndarray, depth_scale: float) -> np.ndarray:
    """``depth`` (H, W) as float64 times ``depth_scale``; non-finite values become 0 (no
    measurement). The one conversion of raw depth into the template's unit."""
    out = np.asarray(depth).astype(np.float64) * float(depth_scale)
    out[~np.isfinite(out)] = 0.0
    return out


def _depth_arg(value: Any) -> np.ndarray:
    try:
        d = np.asarray(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"depth is a {type(value).__name__}, not an (H, W) array of numbers") from None
    if d.dtype.kind not in "uif":
        raise InvalidInputError(
            f"depth has dtype {d.dtype}; pass an (H, W) array of integers or floats (e.g. a 16-bit depth PNG as read)"
        )
    if d.ndim == 3 and d.shape[2] == 1:
        d = d[..., 0]
    if d.ndim != 2 or min(d.shape) == 0:
        raise InvalidInputError(f"depth has shape {d.shape}; expected (H, W), one channel")
    return d


def _K_arg(value: Any) -> np.ndarray:
    try:
        K = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"K is a {type(value).__name__}, not a (3, 3) camera matrix") from None
    if K.size == 9:
        K = K.reshape(3, 3)
    form = "[[fx, 0, cx], [0, fy, cy], [0, 0, 1]] in pixels"
    if K.shape != (3, 3):
        raise InvalidInputError(f"K has shape {K.shape}; pass the camera matrix {form}")
    if not np.isfinite(K).all() or not K.any():
        raise InvalidInputError(f"K {'is all zeros' if np.isfinite(K).all() else 'has a NaN or inf'}; pass {form}")
    if K[2, 0] != 0 or K[2, 1] != 0:
        if K[0, 2] == 0 and K[1, 2] == 0:
            raise InvalidInputError(f"K has cx, cy in its last row: it is transposed; pass K.T ({form})")
        raise InvalidInputError(f"K has last row {K[2].tolist()}; pass the camera matrix {form}")
    if K[2, 2] != 1.0:
        fix = "divide K by it" if K[2, 2] else "pass"
        raise InvalidInputError(f"K[2, 2] is {K[2, 2]:g}, not 1; {fix} ({form})")
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise InvalidInputError(f"K has focal lengths fx={K[0, 0]:g}, fy={K[1, 1]:g}; they must be positive pixels")
    if K[0, 1] != 0 or K[1, 0] != 0:
        raise InvalidInputError(
            f"K has skew or shear ({K[0, 1]:g}, {K[1, 0]:g}); catpose back-projects with a pinhole camera {form}"
        )
    return K


def _mask_arg(value: Any, shape: tuple[int, int]) -> np.ndarray | None:
    if value is None:
        return None
    m = np.asarray(value)
    if m.dtype.kind not in "bui":
        raise InvalidInputError(f"mask has dtype {m.dtype}; pass an (H, W) bool array, True on the object's pixels")
    if m.ndim == 3 and m.shape[2] == 1:
        m = m[..., 0]
    if m.shape != shape:
        raise InvalidInputError(
            f"mask is {m.shape} but depth is {shape}; pass the object's mask at the depth image's size (H, W)"
        )
    return m != 0


@dataclass(frozen=True, eq=False)
class DepthFrame:
    """One depth image, its camera matrix and the object's visible pixels.

    Args:
        depth: (H, W) depth in any integer or float type; ``depth * depth_scale`` is the
            camera-frame z in the template's unit; 0 or NaN where nothing was measured.
        K: (3, 3) pinhole camera matrix ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``, pixels (9
            numbers row by row are accepted, as BOP's ``cam_K``).
        mask: (H, W) bool, the object's visible pixels; None: every measured pixel is the object
            (then no table plane can be fitted, see ``catpose.register``).
        depth_scale: multiplies ``depth`` into the template's unit (BOP: ``depth_scale`` of
            ``scene_camera.json`` gives mm; a metric depth image against a mm template: 1000).
        frame_id: names the frame; with ``seed`` it fixes the frame's random subsets (the
            table-plane RANSAC and the point subset). ``bench run`` passes the observation id.
        seed: see ``frame_id`` (``bench run`` passes its seed).

    Raises:
        InvalidInputError: one line naming the argument and the fix (a depth image of another
            type or shape, negative depth, a matrix that is not a camera matrix, a mask of
            another size, an empty mask or one without measured depth).
    """

    depth: Any
    K: Any
    mask: Any = None
    depth_scale: float = 1.0
    frame_id: str = "frame"
    seed: int = 0
    #: (H, W) float64, ``depth * depth_scale`` with 0 for no measurement (computed once)
    depth_in_unit: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        raw = _depth_arg(self.depth)
        scale = self.depth_scale
        if isinstance(scale, bool) or not isinstance(scale, (int, float, np.integer, np.floating)):
            raise InvalidInputError(f"depth_scale={scale!r} is not a number; pass the factor to the template's unit")
        if not (np.isfinite(scale) and scale > 0):
            raise InvalidInputError(f"depth_scale={scale!r} must be a positive finite number")
        depth = scaled_depth(raw, float(scale))
        if (depth < 0).any():
            raise InvalidInputError(
                f"depth has {int((depth < 0).sum())} negative values; use 0 or NaN for pixels without a measurement"
            )
        valid = depth > 0
        if not valid.any():
            raise InvalidInputError("depth has no measured pixel (all 0 or NaN); pass the frame's depth image")
        K = _K_arg(self.K)
        mask = _mask_arg(self.mask, depth.shape)
        if mask is not None:
            if not mask.any():
                raise InvalidInputError("mask is empty (no True pixel); pass the object's visible pixels")
            if not (mask & valid).any():
                bad = int((mask & ~np.isfinite(np.asarray(raw, float))).sum())
                raise InvalidInputError(
                    f"mask selects {int(mask.sum())} pixels but none has a depth measurement"
                    + (f" ({bad} NaN or inf)" if bad else "")
                    + "; check that mask and depth come from the same (registered) image"
                )
        if not isinstance(self.frame_id, str):
            raise InvalidInputError(f"frame_id={self.frame_id!r} is not a string")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise InvalidInputError(f"seed={self.seed!r} is not an integer")
        set_(self, "depth", raw)
        set_(self, "K", K)
        set_(self, "mask", mask)
        set_(self, "depth_scale", float(scale))
        set_(self, "seed", int(self.seed))
        set_(self, "depth_in_unit", depth)

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the image."""
        return self.depth_in_unit.shape

    @property
    def object_pixels(self) -> np.ndarray:
        """(H, W) bool: the mask's pixels with a depth measurement (every measured pixel without a mask)."""
        valid = self.depth_in_unit > 0
        return valid if self.mask is None else self.mask & valid
