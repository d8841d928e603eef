"""One frame of a BOP dataset as an observation (:class:`~catpose.datasets.bop.BOP`): depth in
mm, the object's pixels (``mask_visib`` or the model rendered at the ground-truth pose), its points
in the object-normalised unit, the ground normal from a RANSAC plane fit to the background, and
the ground-truth pose in the normalised object frame.

:class:`BopFrames` is a mixin of :class:`~catpose.datasets.bop.BOP`; it uses the loader's layout,
JSON cache, mask and plane settings and the model normalisation of
:class:`~catpose.datasets.bop_models.BopModels`.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from catpose import libm
from catpose.datasets.bop_layout import camera_K, gt_obj_id, gt_pose
from catpose.datasets.dataset import Observation
from catpose.datasets.depthio import read_depth, read_mask_png
from catpose.datasets.frame_view import FrameSettings, NoGroundPlane, frame_view
from catpose.datasets.render import PinholeCamera, render_depth
from catpose.depth_frame import DepthFrame, scaled_depth
from catpose.errors import DatasetError, InvalidInputError
from catpose.geometry import apply_R, dot3, make_T, matmul3, norm3


class BopFrame(NamedTuple):
    """One instance of a BOP frame as the loader reads it (:meth:`BopFrames.instance_frame`).

    Attributes:
        frame: the :class:`~catpose.depth_frame.DepthFrame` (raw depth, ``cam_K``, the
            instance's mask, ``depth_scale`` to mm; ``frame_id`` the observation id).
        exclude: (H, W) bool, the rendered model's pixels, left out of the plane fit (mask made by
            rendering), or None.
        category, scene_id, im_id, gt_idx, obj_id: the instance.
        T_camera_model: (4, 4) its ground-truth pose, BOP model frame, mm.
        depth_path: the depth file; mask_source: ``mask_visib`` or ``render``.
    """

    frame: DepthFrame
    exclude: np.ndarray | None
    category: str
    scene_id: int
    im_id: int
    gt_idx: int
    obj_id: int
    T_camera_model: np.ndarray
    depth_path: Path
    mask_source: str


class BopFrames:
    """Observations of a BOP dataset's frames (mixin of ``BOP``)."""

    def frame_settings(self) -> FrameSettings:
        """The dataset config's frame -> view settings (``normal_radius``, ``max_points``, the
        ``plane_*`` keys), as :func:`~catpose.datasets.frame_view.frame_view` takes them."""
        return FrameSettings(
            normal_radius=self.normal_radius,
            max_points=self.max_points,
            plane_distance=self.plane_distance_mm,
            plane_iterations=self.plane_iterations,
            plane_max_points=self.plane_max_points,
        )

    def instance_frame(self, obs_id: str) -> BopFrame:
        """The instance's depth frame (raw depth, ``cam_K``, its mask, ``depth_scale`` to mm, named
        by ``obs_id`` and the run's seed) and what the loader knows beside it (:class:`BopFrame`);
        a bad file or entry raises :class:`DatasetError` naming it."""
        try:
            category, scene_s, im_s, gt_s = obs_id.split("/")
            scene_id, im_id, gt_idx = int(scene_s), int(im_s), int(gt_s)
        except ValueError:
            raise DatasetError(f"observation id {obs_id!r} is not <category>/<scene>/<image>/<gt index>") from None
        gt_path, cam_path = self.layout.scene_gt(scene_id), self.layout.scene_camera(scene_id)
        try:
            gt = self._read_json(gt_path)[str(im_id)][gt_idx]
        except (KeyError, IndexError, TypeError):
            raise DatasetError(f"{gt_path} has no valid pose for image {im_id}, object index {gt_idx}") from None
        obj_id = gt_obj_id(gt_path, str(im_id), gt_idx, gt)
        R_cam_model, t_cam_model = gt_pose(gt_path, im_id, gt_idx, gt)
        K, depth_scale = camera_K(cam_path, self._read_json(cam_path), im_id)
        if self.category_of_object(obj_id) is None:
            raise DatasetError(f"object {obj_id} in {gt_path} is not in dataset.categories; add it there")

        depth_path = self.layout.depth(scene_id, im_id)
        raw_depth = read_depth(depth_path)
        depth_mm = scaled_depth(raw_depth, depth_scale)
        h, w = depth_mm.shape
        camera = PinholeCamera.from_K(K, w, h)
        T_camera_model = make_T(R_cam_model, t_cam_model)

        mask_path = self.layout.mask_visib(scene_id, im_id, gt_idx)
        rendered = None
        if self.mask != "render" and mask_path.is_file():
            mask, source = read_mask_png(mask_path), "mask_visib"
            if mask.shape != depth_mm.shape:
                raise DatasetError(f"{mask_path} is {mask.shape[::-1]} but the depth image is {(w, h)}")
        elif self.mask == "mask_visib":
            raise DatasetError(f"{mask_path} does not exist; set dataset.mask=auto to render the model instead")
        else:
            v_mm, f = self.model_mm(obj_id)
            rendered = render_depth(v_mm, f, T_camera_model, camera).astype(np.float64)
            mask = (rendered > 0) & (depth_mm > 0) & (np.abs(depth_mm - rendered) < self.depth_tolerance_mm)
            source = "render"
        mask &= depth_mm > 0
        n_pix = int(mask.sum())
        if n_pix < max(self.min_visible_pixels, 1):
            raise DatasetError(
                f"object {obj_id} has {n_pix} visible pixels in {depth_path} (mask: {source}); "
                f"at least {self.min_visible_pixels} are needed"
            )
        try:
            frame = DepthFrame(raw_depth, K, mask, depth_scale, frame_id=obs_id, seed=self.seed)
        except InvalidInputError as e:
            raise DatasetError(f"{depth_path}: {e}") from None
        return BopFrame(
            frame,
            None if rendered is None else rendered > 0,
            category,
            scene_id,
            im_id,
            gt_idx,
            obj_id,
            T_camera_model,
            depth_path,
            source,
        )

    def observation(self, obs_id: str) -> Observation:
        bf = self.instance_frame(obs_id)
        category, scene_id, im_id, gt_idx, obj_id = bf.category, bf.scene_id, bf.im_id, bf.gt_idx, bf.obj_id
        R_cam_model, t_cam_model = bf.T_camera_model[:3, :3], bf.T_camera_model[:3, 3]
        R_obj_model, centre, scale = self.normalisation(obj_id)
        # the same frame -> view path as catpose.register(DepthFrame(...)) (datasets/frame_view.py)
        try:
            view = frame_view(bf.frame, scale, self.frame_settings(), exclude=bf.exclude, source=str(bf.depth_path))
        except NoGroundPlane as e:
            raise DatasetError(str(e)) from None
        depth_mm = float(np.median(bf.frame.depth_in_unit[bf.frame.object_pixels]))
        pts = view.points_camera
        radius = norm3(pts.max(axis=0) - pts.min(axis=0)) / 2 if len(pts) else 0.0
        if not (0.5 < depth_mm / t_cam_model[2] < 2 and radius > 0.05):  # a view spans 0.3 to 1.2 model radii
            raise DatasetError(
                f"{bf.depth_path}: object {obj_id} is seen at {depth_mm:.4g} mm but cam_t_m2c puts it at "
                f"{t_cam_model[2]:.4g} mm, and its visible points span {radius:.3g} radii of its model "
                f"{self.layout.model(obj_id)}: the depth and the model are in different units; fix depth_scale in "
                "scene_camera.json or the model's unit (mm)"
            )

        # p_object = R_obj_model R^T (p_cam - t) / s - centre / s, with p_cam in mm
        R_object_camera = matmul3(R_obj_model, R_cam_model.T)
        T_object_camera = make_T(R_object_camera, -(apply_R(R_object_camera, t_cam_model) + centre) / scale)
        up_camera = apply_R(R_object_camera.T, np.array([0.0, 0.0, 1.0]))
        ground_err = float(np.degrees(libm.arccos(np.clip(dot3(view.ground_normal_camera, up_camera), -1.0, 1.0))))
        return Observation(
            obs_id=obs_id,
            category=category,
            instance_id=f"obj_{obj_id:06d}",
            points_camera=view.points_camera,
            normals_camera=view.normals_camera,
            ground_normal_camera=view.ground_normal_camera,
            T_object_camera=T_object_camera,
            symmetry_axis=self.symmetry_axis(obj_id, category),
            symmetries=self.discrete_symmetries(obj_id),
            depth_image=view.depth_image,
            info={
                "scene_id": scene_id,
                "im_id": im_id,
                "gt_idx": gt_idx,
                "obj_id": obj_id,
                "mask_source": bf.mask_source,
                "visible_pixels": view.visible_pixels,
                "ground_inliers": view.ground_inliers,
                "ground_vs_object_up_deg": ground_err,
                "scale_mm": scale,
                "centre_mm": [float(x) for x in centre],
                "R_object_model": [float(x) for x in R_obj_model.ravel()],
                "bop_filters": "; ".join(self.filters) or "none",
            },
        )
