"""One frame of a BOP dataset as an observation (:class:`~catpose.datasets.bop.BOP`): depth in
mm, the object's pixels (``mask_visib`` or the model rendered at the ground-truth pose), its points
in the object-normalised unit, the ground normal from a RANSAC plane fit to the background, and
the ground-truth pose in the normalised object frame.

:class:`BopFrames` is a mixin of :class:`~catpose.datasets.bop.BOP`; it uses the loader's layout,
JSON cache, mask and plane settings and the model normalisation of
:class:`~catpose.datasets.bop_models.BopModels`.
"""

from __future__ import annotations

import numpy as np

from catpose import libm
from catpose.datasets.bop_layout import camera_K
from catpose.datasets.dataset import Observation
from catpose.datasets.depthio import fit_ground_plane, read_depth, read_mask_png
from catpose.datasets.render import PinholeCamera, depth_to_points, estimate_normals, render_depth
from catpose.errors import DatasetError
from catpose.geometry import apply_R, dot3, make_T, matmul3, stable_seed
from catpose.types import DepthImage


class BopFrames:
    """Observations of a BOP dataset's frames (mixin of ``BOP``)."""

    def observation(self, obs_id: str) -> Observation:
        try:
            category, scene_s, im_s, gt_s = obs_id.split("/")
            scene_id, im_id, gt_idx = int(scene_s), int(im_s), int(gt_s)
        except ValueError:
            raise DatasetError(f"observation id {obs_id!r} is not <category>/<scene>/<image>/<gt index>") from None
        gt_path, cam_path = self.layout.scene_gt(scene_id), self.layout.scene_camera(scene_id)
        try:
            gt = self._read_json(gt_path)[str(im_id)][gt_idx]
            obj_id = int(gt["obj_id"])
            R_cam_model = np.asarray(gt["cam_R_m2c"], float).reshape(3, 3)
            t_cam_model = np.asarray(gt["cam_t_m2c"], float).reshape(3)
        except (KeyError, IndexError, TypeError, ValueError):
            raise DatasetError(f"{gt_path} has no valid pose for image {im_id}, object index {gt_idx}") from None
        K, depth_scale = camera_K(cam_path, self._read_json(cam_path), im_id)
        if self.category_of_object(obj_id) is None:
            raise DatasetError(f"object {obj_id} in {gt_path} is not in dataset.categories; add it there")

        depth_path = self.layout.depth(scene_id, im_id)
        depth_mm = read_depth(depth_path).astype(np.float64) * depth_scale
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
        if n_pix < self.min_visible_pixels:
            raise DatasetError(
                f"object {obj_id} has {n_pix} visible pixels in {depth_path} (mask: {source}); "
                f"at least {self.min_visible_pixels} are needed"
            )

        R_obj_model, centre, scale = self.normalisation(obj_id)
        points_mm, _ = depth_to_points(depth_mm, camera, mask)
        points = points_mm / scale

        # background for the ground plane: everything not the object (nor where the model is)
        background = (depth_mm > 0) & ~mask
        if rendered is not None:
            background &= rendered <= 0
        bg_points, _ = depth_to_points(depth_mm, camera, background)
        rng = np.random.default_rng(stable_seed(self.seed, "bop", obs_id))
        if self.plane_max_points and len(bg_points) > self.plane_max_points:
            bg_points = bg_points[rng.choice(len(bg_points), size=self.plane_max_points, replace=False)]
        if len(bg_points) < 100:
            raise DatasetError(f"{depth_path}: only {len(bg_points)} background pixels; cannot fit the ground plane")
        ground, _, n_inliers = fit_ground_plane(
            bg_points, self.plane_distance_mm, self.plane_iterations, stable_seed(self.seed, "plane", obs_id)
        )

        normals = estimate_normals(points, self.normal_radius)
        if self.max_points and len(points) > self.max_points:
            keep = np.sort(rng.choice(len(points), size=self.max_points, replace=False))
            points, normals = points[keep], normals[keep]

        # p_object = R_obj_model R^T (p_cam - t) / s - centre / s, with p_cam in mm
        R_object_camera = matmul3(R_obj_model, R_cam_model.T)
        T_object_camera = make_T(R_object_camera, -(apply_R(R_object_camera, t_cam_model) + centre) / scale)
        up_camera = apply_R(R_object_camera.T, np.array([0.0, 0.0, 1.0]))
        ground_err = float(np.degrees(libm.arccos(np.clip(dot3(ground, up_camera), -1.0, 1.0))))
        return Observation(
            obs_id=obs_id,
            category=category,
            instance_id=f"obj_{obj_id:06d}",
            points_camera=points,
            normals_camera=normals,
            ground_normal_camera=ground,
            T_object_camera=T_object_camera,
            symmetry_axis=self.symmetry_axis(obj_id, category),
            symmetries=self.discrete_symmetries(obj_id),
            depth_image=DepthImage(depth_mm / scale, K, mask),
            info={
                "scene_id": scene_id,
                "im_id": im_id,
                "gt_idx": gt_idx,
                "obj_id": obj_id,
                "mask_source": source,
                "visible_pixels": n_pix,
                "ground_inliers": n_inliers,
                "ground_vs_object_up_deg": ground_err,
                "scale_mm": scale,
                "centre_mm": [float(x) for x in centre],
                "R_object_model": [float(x) for x in R_obj_model.ravel()],
                "bop_filters": "; ".join(self.filters) or "none",
            },
        )
