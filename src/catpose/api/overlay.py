"""``catpose.overlay``: a registration drawn on its depth frame, to see the pose and judge it.

The template is rendered at the answer (green: filled, outlined) and, when the method named one,
at its runner-up (magenta outline; :attr:`~catpose.api.result.Registration.runner_up`), each with
the template's axes drawn from its centre, +z (up, ending in a dot) and +x (forward): a half turn
covers the same pixels, its axes do not. Under them the depth image in grey (near is bright, no
measurement black) and the object's mask outlined in yellow. A line above the image gives the method, the runner-up's margin and whether the answer
is :attr:`~catpose.api.result.Registration.ambiguous`. A mesh template is rendered by
:func:`catpose.datasets.render.render_depth` (the renderer of the synthetic sets); a point-cloud
template is drawn as its projected points.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from catpose.api.inputs import NormalisedTemplate, normalised_template
from catpose.api.result import Registration
from catpose.depth_frame import DepthFrame
from catpose.errors import InvalidInputError

__all__ = ["ANSWER_RGB", "RUNNER_UP_RGB", "overlay"]

ANSWER_RGB = (40, 220, 90)
RUNNER_UP_RGB = (235, 50, 220)
MASK_RGB = (250, 220, 40)
#: images narrower than this are enlarged by a whole factor (pixels kept square and sharp)
MIN_WIDTH = 480


def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` without BLAS: the same pixels on every CPU."""
    return np.einsum("ij,jk->ik", a, b)


def overlay(frame: DepthFrame, result: Registration, template: Any, path: str | Path | None = None) -> np.ndarray:
    """Draw ``template`` at ``result``'s answer and runner-up on ``frame``'s depth image.

    Args:
        frame: the :class:`~catpose.depth_frame.DepthFrame` that was registered.
        result: what :func:`catpose.register` returned for it (poses ``T_template_camera``,
            template frame and unit).
        template: the template passed to ``register`` (a mesh file, a mesh, a point array or a
            :class:`~catpose.api.inputs.NormalisedTemplate`).
        path: write the picture there as a PNG (atomically; its folder is created), or None.

    Returns:
        (H', W', 3) uint8 RGB picture (``H' = k H``, ``W' = k W``: small frames are enlarged by a
        whole factor ``k`` for legibility) with a caption band above it.
    """
    if not isinstance(frame, DepthFrame):
        raise InvalidInputError(f"overlay: frame is a {type(frame).__name__}; pass the DepthFrame that was registered")
    if not isinstance(result, Registration):
        raise InvalidInputError(f"overlay: result is a {type(result).__name__}; pass what catpose.register returned")
    tmpl = (
        template
        if isinstance(template, NormalisedTemplate)
        else normalised_template(template, None, np.array([0.0, 0.0, 1.0]), 2048)
    )
    image = _grey(frame.depth_in_unit)
    poses = [(np.asarray(result.T_template_camera, float), ANSWER_RGB)]
    if result.runner_up is not None:
        poses.append((np.asarray(result.runner_up, float), RUNNER_UP_RGB))
    seen = [_silhouette(frame, tmpl, T) for T, _ in poses]
    outlines = [(_outline(s), rgb) for s, (_, rgb) in zip(seen, poses)]
    answer = seen[0]
    image[answer] = (0.55 * image[answer] + 0.45 * np.array(ANSWER_RGB)).astype(np.uint8)
    if frame.mask is not None:
        outlines.insert(0, (_outline(frame.mask), MASK_RGB))
    for pixels, rgb in outlines:  # the runner-up's last: a half turn shares the answer's outline
        image[pixels] = rgb
    k = max(1, -(-MIN_WIDTH // image.shape[1]))
    image = _with_axes(np.repeat(np.repeat(image, k, axis=0), k, axis=1), k, frame.K, tmpl, poses)
    picture = _captioned(image, _caption(result))
    if path is not None:
        from PIL import Image

        from catpose.atomic import atomic_path

        with atomic_path(path) as tmp:
            Image.fromarray(picture).save(tmp, format="PNG")
    return picture


def _grey(depth: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8: measured depth in grey, near bright (1st-99th percentile stretched)."""
    valid = np.isfinite(depth) & (depth > 0)
    out = np.zeros((*depth.shape, 3), np.uint8)
    if valid.any():
        lo, hi = np.percentile(depth[valid], [1.0, 99.0])
        level = 1.0 - np.clip((depth[valid] - lo) / max(hi - lo, 1e-12), 0.0, 1.0)
        out[valid] = (40.0 + 190.0 * level).astype(np.uint8)[:, None]
    return out


def _silhouette(frame: DepthFrame, tmpl: NormalisedTemplate, T_template_camera: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels the template covers at ``T_template_camera`` (caller's frame)."""
    from catpose.geometry import invert_T

    T_camera_template = invert_T(T_template_camera)
    t = tmpl.template
    to_caller = lambda p: _mul(tmpl.scale * np.asarray(p, float) + tmpl.centre, tmpl.R_up)  # noqa: E731
    height, width = frame.shape
    if t.vertices is not None and t.triangles is not None:
        from catpose.datasets.render import PinholeCamera, render_depth

        camera = PinholeCamera.from_K(frame.K, width, height)
        return render_depth(to_caller(t.vertices), np.asarray(t.triangles), T_camera_template, camera) > 0
    p = _mul(to_caller(t.points), T_camera_template[:3, :3].T) + T_camera_template[:3, 3]
    p = p[p[:, 2] > 0]
    uv = np.rint(_mul(p[:, :2] / p[:, 2:], frame.K[:2, :2].T) + frame.K[:2, 2]).astype(int)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < width) & (uv[:, 1] >= 0) & (uv[:, 1] < height)
    seen = np.zeros((height, width), bool)
    seen[uv[inside, 1], uv[inside, 0]] = True
    return seen


def _with_axes(
    image: np.ndarray, k: int, K: np.ndarray, tmpl: NormalisedTemplate, poses: list[tuple[np.ndarray, tuple]]
) -> np.ndarray:
    """Each pose's template axes from the template's centre: up (+z, 0.8 radii, a dot at its tip)
    and forward (+x, 0.5 radii): what tells a pose from its half turn when both cover the same
    pixels."""
    from PIL import Image, ImageDraw

    from catpose.geometry import invert_T

    # the normalised origin, +z and +x in the caller's template frame
    ends = _mul(tmpl.centre + tmpl.scale * np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.8], [0.5, 0.0, 0.0]]), tmpl.R_up)
    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    for T_template_camera, rgb in poses[::-1]:
        T = invert_T(T_template_camera)
        p = _mul(ends, T[:3, :3].T) + T[:3, 3]
        if (p[:, 2] <= 0).any():
            continue
        (u0, v0), (u1, v1), (u2, v2) = k * (_mul(p[:, :2] / p[:, 2:], K[:2, :2].T) + K[:2, 2] + 0.5)
        draw.line([(u0, v0), (u2, v2)], fill=rgb, width=max(1, k - 1))
        draw.line([(u0, v0), (u1, v1)], fill=rgb, width=max(2, k + 1))
        r = 2 + k
        draw.ellipse([u1 - r, v1 - r, u1 + r, v1 + r], fill=rgb, outline=(0, 0, 0))
    return np.asarray(picture)


def _outline(mask: np.ndarray) -> np.ndarray:
    """The pixels of ``mask`` with a 4-neighbour outside it (a one-pixel border)."""
    from scipy.ndimage import binary_erosion

    mask = np.asarray(mask, bool)
    return mask & ~binary_erosion(mask, border_value=0)


def _caption(result: Registration) -> str:
    if result.runner_up is None:
        return f"{result.method}: answer (green; lines: template up (dot) and forward); no runner-up named"
    verdict = "AMBIGUOUS: check both" if result.ambiguous else "clear"
    return (
        f"{result.method}: answer (green), runner-up (magenta), lines: template up (dot) and forward; "
        f"margin {result.runner_up_margin:.4f}: {verdict}"
    )


def _captioned(image: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    band = Image.new("RGB", (image.shape[1], 22), (0, 0, 0))
    ImageDraw.Draw(band).text((4, 5), text, fill=(255, 255, 255))
    return np.concatenate([np.asarray(band), image], axis=0)
