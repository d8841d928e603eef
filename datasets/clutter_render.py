"""Render a cluttered scene (:mod:`catpose.datasets.clutter_layout`) and write it in the BOP layout.

Rendering is exact ray casting, the same bits on every CPU: each object is cast only inside the
window its projected vertices cover (:class:`catpose.raycast.RayCaster`, hits recomputed in
float64), the table plane in closed form; the scene depth is the nearest of them per pixel, which
is what casting the whole scene as one mesh gives. An object's full mask is where it is hit at
all; its visible mask where it is the nearest surface. The depth-sensor model
(:func:`catpose.datasets.sensor.apply_sensor`: noise, edges, quantisation, dropout) is applied to
the whole scene; each object's ``mask_visib`` is its visible mask dilated by the sensor's mask
bleed and restricted to measured depth, the segmentation a real pipeline would hand over.

With a sensor model, three effects measured on the real YCB-Video frames
(``python experiments/_lib/sensor_stats.py``) follow, each in a strength drawn per scene or
object from the spec's range (:func:`scene_effects`): depth lost in patches of an object (dark or
shiny parts: a smooth random field over the object's pixels, thresholded at the drawn fraction),
the segmentation shifted against the depth by a pixel or two (depth-to-colour registration), and
a written ground truth a few millimetres and a fraction of a degree off the pose that was
rendered (annotations).

Files of one scene (one image, ``im_id`` 0), as the BOP toolkit writes them::

    <split>/<scene_id:06d>/depth/000000.png            uint16, value * depth_scale = mm
    <split>/<scene_id:06d>/mask/000000_<k:06d>.png      the k-th object's full silhouette
    <split>/<scene_id:06d>/mask_visib/000000_<k:06d>.png   its visible pixels (with the bleed)
    <split>/<scene_id:06d>/scene_gt.json, scene_camera.json, scene_gt_info.json

A scene is written into a temporary folder and renamed into place, so a killed or concurrent
generation never leaves half a scene.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from catpose.datasets.clutter_layout import ClutterSpec, SceneLayout, T_camera_model
from catpose.datasets.render import PinholeCamera
from catpose.datasets.sensor import apply_sensor, get_sensor
from catpose.geometry import apply_R, axis_angle_to_R, compose_T, dot3, make_T, norm3, stable_seed, transform_points
from catpose.raycast import RayCaster


@dataclass(frozen=True)
class SceneImage:
    """A rendered scene: ``depth_mm`` (H, W) after the sensor model (0: no measurement), per object
    ``full`` and ``visible`` (H, W) bool true masks and ``mask_visib`` the written segmentation."""

    depth_mm: np.ndarray
    full: list[np.ndarray]
    visible: list[np.ndarray]
    mask_visib: list[np.ndarray]
    annotation: list[np.ndarray] | None = None  # per object (4, 4) T_written_true (mm); None: exact


def pixel_rays(camera: PinholeCamera, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """(..., 3) camera-frame ray directions ``((col - cx) / fx, (row - cy) / fy, 1)`` of pixels."""
    rows, cols = np.asarray(rows, np.float64), np.asarray(cols, np.float64)
    return np.stack([(cols - camera.cx) / camera.fx, (rows - camera.cy) / camera.fy, np.ones_like(cols)], axis=-1)


def object_depth(caster: RayCaster, T_camera_model: np.ndarray, camera: PinholeCamera, margin: int = 2) -> np.ndarray:
    """(H, W) depth (mm, camera z) of one model alone, 0 where it is not hit; rays are cast only
    inside the bounding box of its projected vertices (plus ``margin`` pixels)."""
    out = np.zeros((camera.height, camera.width))
    v = transform_points(T_camera_model, caster.vertices)
    if (v[:, 2] <= 1e-6).any():
        return out  # reaches behind the camera: not in this image (never for the default spec)
    u, w = camera.fx * v[:, 0] / v[:, 2] + camera.cx, camera.fy * v[:, 1] / v[:, 2] + camera.cy
    c0, c1 = max(int(np.floor(u.min())) - margin, 0), min(int(np.ceil(u.max())) + margin, camera.width - 1)
    r0, r1 = max(int(np.floor(w.min())) - margin, 0), min(int(np.ceil(w.max())) + margin, camera.height - 1)
    if c0 > c1 or r0 > r1:
        return out
    rows, cols = np.mgrid[r0 : r1 + 1, c0 : c1 + 1]
    R_model_camera = T_camera_model[:3, :3].T
    origin = -apply_R(R_model_camera, T_camera_model[:3, 3])  # the camera centre, model frame
    s = caster.cast(origin, apply_R(R_model_camera, pixel_rays(camera, rows, cols)))
    out[r0 : r1 + 1, c0 : c1 + 1] = np.where(np.isfinite(s) & (s > 0), s, 0.0)
    return out


def table_depth(T_camera_world: np.ndarray, camera: PinholeCamera) -> np.ndarray:
    """(H, W) depth (mm) of the table plane ``z_world = 0`` in closed form, 0 above the horizon."""
    rows, cols = np.mgrid[0 : camera.height, 0 : camera.width]
    d = pixel_rays(camera, rows, cols)
    n = T_camera_world[:3, 2]  # the world's z axis in the camera frame
    nd = dot3(d, np.broadcast_to(n, d.shape))
    s = dot3(n, T_camera_world[:3, 3]) / np.where(nd == 0.0, 1.0, nd)
    return np.where((nd != 0.0) & (s > 0), s, 0.0)


def render_scene(spec: ClutterSpec, layout: SceneLayout, casters: dict[int, RayCaster]) -> SceneImage:
    """The scene's depth image and masks (see the module docstring); a pure function of its inputs."""
    from scipy.ndimage import binary_dilation

    K = np.asarray(spec.K)
    camera = PinholeCamera.from_K(K, spec.width, spec.height)
    depths = [object_depth(casters[o.obj_id], T_camera_model(layout, o), camera) for o in layout.objects]
    stack = np.stack([table_depth(layout.T_camera_world, camera)] + depths)  # (1 + n, H, W)
    nearest = np.where(stack > 0, stack, np.inf).min(axis=0)
    clean = np.where(np.isfinite(nearest), nearest, 0.0)
    full = [d > 0 for d in depths]
    visible = [(d > 0) & (d <= clean) for d in depths]
    sensor = get_sensor(spec.sensor)
    if sensor is None:
        return SceneImage(clean, full, visible, [v & (clean > 0) for v in visible])
    rng = np.random.default_rng(stable_seed(spec.scene_seed, "clutter-sensor", layout.scene_id))
    any_object = np.any(np.stack(visible), axis=0) if visible else np.zeros(clean.shape, bool)
    depth_m, _ = apply_sensor(clean / 1000.0, any_object, camera.fx, camera.fy, camera.cx, camera.cy, sensor, rng)
    bleed = int(sensor.mask_bleed_px)
    masks = [binary_dilation(v, iterations=bleed) if bleed > 0 and v.any() else v for v in visible]
    effects = np.random.default_rng(stable_seed(spec.scene_seed, "clutter-effects", layout.scene_id))
    depth_m, masks, annotation = scene_effects(spec, effects, depth_m, visible, masks)
    return SceneImage(depth_m * 1000.0, full, visible, [m & (depth_m > 0) for m in masks], annotation)


#: spatial scale (pixels, Gaussian sigma) of the patches of lost depth
BLOB_SIGMA_PX = 4.0


def scene_effects(
    spec: ClutterSpec, rng: np.random.Generator, depth_m: np.ndarray, visible: list[np.ndarray], masks: list[np.ndarray]
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """The measured effects the sensor model lacks (module docstring): returns the depth with
    patches lost, the segmentations shifted against it, and per object ``T_written_true`` (4, 4,
    mm: the written ground truth is ``T_written_true @ T_camera_model``)."""
    from scipy.ndimage import gaussian_filter, shift

    depth = np.array(depth_m, copy=True)
    for v in visible:
        f = float(rng.uniform(*spec.dropout_blobs))
        rows, cols = np.nonzero(v)
        if f <= 0 or len(rows) == 0:
            continue
        r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
        field = gaussian_filter(rng.normal(size=(r1 - r0, c1 - c0)), BLOB_SIGMA_PX)
        box = v[r0:r1, c0:c1]
        lost = box & (field <= np.quantile(field[box], f))
        depth[r0:r1, c0:c1][lost] = 0.0
    length, angle = float(rng.uniform(*spec.mask_shift_px)), float(rng.uniform(0.0, 2.0 * np.pi))
    dy, dx = int(np.rint(length * np.sin(angle))), int(np.rint(length * np.cos(angle)))
    masks = [shift(m, (dy, dx), order=0, mode="constant", cval=False) if (dx or dy) else m for m in masks]
    sigma_t, sigma_r = float(rng.uniform(*spec.annotation_mm)), float(rng.uniform(*spec.annotation_deg))
    annotation = []
    for _ in visible:
        axis = rng.normal(size=3)
        R = axis_angle_to_R(axis / max(norm3(axis), 1e-12), np.deg2rad(sigma_r * float(rng.normal())))
        annotation.append(make_T(R, sigma_t * rng.normal(size=3)))
    return depth, masks, annotation


def _bbox(mask: np.ndarray) -> list[int]:
    """BOP ``[x, y, w, h]`` of a mask's pixels (``[-1, -1, -1, -1]`` when empty)."""
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return [-1, -1, -1, -1]
    return [int(cols.min()), int(rows.min()), int(cols.max() - cols.min() + 1), int(rows.max() - rows.min() + 1)]


def _write_png(path: Path, array: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(array).save(path)


def write_scene(split_dir: Path, spec: ClutterSpec, layout: SceneLayout, image: SceneImage) -> Path:
    """Write one rendered scene as ``split_dir/<scene_id:06d>/`` (atomically; see the module doc)."""
    final = Path(split_dir) / f"{layout.scene_id:06d}"
    tmp = Path(split_dir) / f".tmp-{layout.scene_id:06d}-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    for sub in ("depth", "mask", "mask_visib"):
        (tmp / sub).mkdir(parents=True)
    raw = np.rint(image.depth_mm / spec.depth_scale)
    _write_png(tmp / "depth" / "000000.png", np.clip(raw, 0, 65535).astype(np.uint16))
    gts, infos = [], []
    for k, (obj, full, vis, seg) in enumerate(zip(layout.objects, image.full, image.visible, image.mask_visib)):
        _write_png(tmp / "mask" / f"000000_{k:06d}.png", (full * 255).astype(np.uint8))
        _write_png(tmp / "mask_visib" / f"000000_{k:06d}.png", (seg * 255).astype(np.uint8))
        T = T_camera_model(layout, obj)
        if image.annotation is not None:  # the annotation's error, as on real frames
            T = compose_T(image.annotation[k], T)
        gts.append(
            {
                "cam_R_m2c": [float(x) for x in T[:3, :3].ravel()],
                "cam_t_m2c": [float(x) for x in T[:3, 3]],
                "obj_id": int(obj.obj_id),
            }
        )
        n_all, n_vis = int(full.sum()), int(vis.sum())
        infos.append(
            {
                "bbox_obj": _bbox(full),
                "bbox_visib": _bbox(vis),
                "px_count_all": n_all,
                "px_count_valid": int((full & (image.depth_mm > 0)).sum()),
                "px_count_visib": n_vis,
                "visib_fract": float(n_vis / n_all) if n_all else 0.0,
                "rest_up": [float(x) for x in obj.rest_up],
            }
        )
    K = np.asarray(spec.K)
    camera = {
        "0": {
            "cam_K": [float(x) for x in K.ravel()],
            "depth_scale": float(spec.depth_scale),
            "cam_R_w2c": [float(x) for x in layout.T_camera_world[:3, :3].ravel()],
            "cam_t_w2c": [float(x) for x in layout.T_camera_world[:3, 3]],
        }
    }
    (tmp / "scene_gt.json").write_text(json.dumps({"0": gts}, indent=1))
    (tmp / "scene_gt_info.json").write_text(json.dumps({"0": infos}, indent=1))
    (tmp / "scene_camera.json").write_text(json.dumps(camera, indent=1))
    try:
        os.replace(tmp, final)
    except OSError:  # another process wrote the scene first: theirs is the same scene
        shutil.rmtree(tmp, ignore_errors=True)
    return final
