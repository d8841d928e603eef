"""Camera set-up shared by the rendered datasets (synthetic, ModelNet40).

Their configs give the pinhole intrinsics as plain numbers with an optional principal point;
:func:`pinhole_camera` turns them into a :class:`~catpose.datasets.render.PinholeCamera` so the
"None means the image centre" rule lives in one place.
"""

from __future__ import annotations

from catpose.datasets.render import PinholeCamera


def pinhole_camera(
    width: int, height: int, fx: float, fy: float, cx: float | None = None, cy: float | None = None
) -> PinholeCamera:
    """A pinhole camera whose principal point defaults to the image centre.

    Args:
        width, height: image size in pixels.
        fx, fy: focal lengths in pixels.
        cx, cy: principal point in pixels; None means ``(width - 1) / 2`` and
            ``(height - 1) / 2`` (the centre of the pixel grid).
    """
    width, height = int(width), int(height)
    for name, value in (("fx", fx), ("fy", fy)):
        if not float(value) > 0 or float(value) == float("inf"):
            from catpose.errors import ConfigError

            raise ConfigError(f"dataset.{name}={value}: pass a positive focal length in pixels (e.g. 300)")
    return PinholeCamera(
        width,
        height,
        float(fx),
        float(fy),
        float((width - 1) / 2 if cx is None else cx),
        float((height - 1) / 2 if cy is None else cy),
    )
