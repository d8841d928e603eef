"""The BOP dataset layout: where each file of a BOP dataset lives (models, models_eval, depth in
PNG or TIFF, multi-sensor folders), and the readers of its JSON files (cameras, ground truth,
targets, visible fractions, symmetries), each failing in one line that names the file.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from catpose.errors import DatasetError
from catpose.geometry import apply_R, dot3, unit3

ROTATION_TOL = 1e-3
"""Largest entry of ``|R^T R - I|`` and of ``|det R - 1|`` accepted for a rotation, in ground
truth and in results files (they hold rounded values; 9 significant digits give about 1e-9)."""


def rotation_problem(R: np.ndarray, tol: float = ROTATION_TOL) -> str | None:
    """Why the (3, 3) ``R`` is not a rotation within ``tol`` (None when it is one)."""
    R = np.asarray(R, float).reshape(3, 3)
    if not np.isfinite(R).all():
        return "it has a NaN or infinite value"
    orth = float(np.abs(np.einsum("ji,jk->ik", R, R) - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if orth <= tol and abs(det - 1.0) <= tol:
        return None
    return f"max |R^T R - I| = {orth:.6g}, det R = {det:.6g}"


def gt_pose(gt_path: Path, im_key: str | int, gt_idx: int, entry: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(R_camera_model (3, 3), t_camera_model (3,) mm)`` of entry ``gt_idx`` of image ``im_key`` in a
    ``scene_gt.json``: a :class:`DatasetError` naming the file when it is missing, not a rotation
    within :data:`ROTATION_TOL` or not finite (a zero matrix would score every estimate 0 deg)."""
    where = f"{gt_path}: image {im_key}, object index {gt_idx}"
    try:
        R = np.asarray(entry["cam_R_m2c"], float).reshape(3, 3)
        t = np.asarray(entry["cam_t_m2c"], float).reshape(3)
    except (KeyError, IndexError, TypeError, ValueError):
        raise DatasetError(f"{where} has no valid pose: cam_R_m2c must be 9 numbers, cam_t_m2c 3") from None
    why = rotation_problem(R)
    if why:
        raise DatasetError(
            f"{where}: cam_R_m2c is not a rotation ({why}); fix the file (9 row-major numbers of an orthonormal "
            f"matrix with det +1, within {ROTATION_TOL:g})"
        )
    if not np.isfinite(t).all():
        raise DatasetError(f"{where}: cam_t_m2c {t.tolist()} is not 3 finite numbers (mm); fix the file")
    return R, t


def read_json(path: Path) -> Any:
    """Load a JSON file, raising :class:`DatasetError` naming it when missing or malformed."""
    if not path.is_file():
        raise DatasetError(f"{path} does not exist; check dataset.root and dataset.split")
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path} is not valid JSON ({exc}); re-download it") from None


def camera_K(cam_path: Path, cameras: Any, im_id: int | str) -> tuple[np.ndarray, float]:
    """``cam_K`` (3, 3, pixels) and ``depth_scale`` of image ``im_id`` in a ``scene_camera.json``
    (already loaded as ``cameras``); a :class:`DatasetError` naming the file when the entry is
    missing or malformed, or when a focal length is not a positive finite number of pixels."""
    try:
        cam = cameras[str(im_id)]
        K = np.asarray(cam["cam_K"], float).reshape(3, 3)
    except (KeyError, TypeError, ValueError, AttributeError):
        raise DatasetError(f"{cam_path} has no valid cam_K for image {im_id}") from None
    raw = cam.get("depth_scale", 1.0)
    depth_scale = float(raw) if isinstance(raw, (int, float)) and not isinstance(raw, bool) else float("nan")
    if not (np.isfinite(depth_scale) and depth_scale > 0):
        raise DatasetError(
            f"{cam_path}: depth_scale of image {im_id} is {raw!r}; it must be a positive number (mm per depth "
            "unit: 1 for depth PNGs in mm, 0.1 for YCB-Video)"
        )
    fx, fy = float(K[0, 0]), float(K[1, 1])
    if not (np.isfinite(K).all() and fx > 0 and fy > 0):
        raise DatasetError(
            f"{cam_path}: cam_K of image {im_id} has focal lengths fx={fx:g}, fy={fy:g}"
            + ("" if np.isfinite(K).all() else " and a NaN or infinite value")
            + "; they must be positive pixels: fix cam_K (row-major [fx, 0, cx, 0, fy, cy, 0, 0, 1])"
        )
    return K, depth_scale


def gt_obj_id(gt_path: Path, im_key: str, gt_idx: int, entry: Any) -> int:
    """``obj_id`` of entry ``gt_idx`` of image ``im_key`` in a ``scene_gt.json``; a
    :class:`DatasetError` naming the file when it is missing or not an integer."""
    try:
        return int(entry["obj_id"])
    except (KeyError, TypeError, ValueError):
        raise DatasetError(
            f"{gt_path}: entry {gt_idx} of image {im_key} has no integer obj_id; every entry "
            "needs obj_id, cam_R_m2c and cam_t_m2c (BOP format)"
        ) from None


class BopLayout:
    """File paths of one BOP dataset split (bop_toolkit's ``dataset_params`` conventions).

    Args:
        root: dataset folder (``<models_dir>/``, ``<split>/``, ``test_targets_bop19.json``).
        split: e.g. ``"test"``.
        models_dir: ``"models"`` or ``"models_eval"`` (the BOP evaluation models).
        depth_ext: ``".png"`` (most datasets) or ``".tif"`` (ITODD).
        sensor: multi-sensor layouts (BOP-H3: ``depth_<sensor>/``, ``scene_gt_<sensor>.json``,
            ``scene_camera_<sensor>.json``, ...); None for the classic layout.
    """

    def __init__(
        self,
        root: str | Path,
        split: str = "test",
        models_dir: str = "models",
        depth_ext: str = ".png",
        sensor: str | None = None,
    ) -> None:
        self.root = Path(root)
        self.split = str(split)
        self.models_dir = str(models_dir)
        ext = str(depth_ext)
        self.depth_ext = ext if ext.startswith(".") else "." + ext
        if self.depth_ext.lower() not in (".png", ".tif", ".tiff"):
            raise DatasetError(f"dataset.depth_ext {depth_ext!r} is not .png or .tif")
        self.sensor = None if sensor in (None, "", "none") else str(sensor)  # none: a single-sensor layout

    @property
    def _sfx(self) -> str:
        return "" if self.sensor is None else f"_{self.sensor}"

    def split_dir(self) -> Path:
        return self.root / self.split

    def scene_dir(self, scene_id: int) -> Path:
        return self.split_dir() / f"{int(scene_id):06d}"

    def scene_gt(self, scene_id: int) -> Path:
        return self.scene_dir(scene_id) / f"scene_gt{self._sfx}.json"

    def scene_gt_info(self, scene_id: int) -> Path:
        return self.scene_dir(scene_id) / f"scene_gt_info{self._sfx}.json"

    def scene_camera(self, scene_id: int) -> Path:
        return self.scene_dir(scene_id) / f"scene_camera{self._sfx}.json"

    def depth(self, scene_id: int, im_id: int) -> Path:
        return self.scene_dir(scene_id) / f"depth{self._sfx}" / f"{int(im_id):06d}{self.depth_ext}"

    def mask_visib(self, scene_id: int, im_id: int, gt_idx: int) -> Path:
        return self.scene_dir(scene_id) / f"mask_visib{self._sfx}" / f"{int(im_id):06d}_{int(gt_idx):06d}.png"

    def model(self, obj_id: int) -> Path:
        return self.root / self.models_dir / f"obj_{int(obj_id):06d}.ply"

    def models_info(self) -> Path:
        return self.root / self.models_dir / "models_info.json"

    def targets(self, name: str) -> Path:
        return self.root / name


def read_targets(path: Path) -> dict[tuple[int, int, int], int]:
    """``test_targets_bop19.json``: (scene_id, im_id, obj_id) -> number of instances to find."""
    data = read_json(path)
    out: dict[tuple[int, int, int], int] = {}
    try:
        for t in data:
            key = (int(t["scene_id"]), int(t["im_id"]), int(t["obj_id"]))
            out[key] = out.get(key, 0) + int(t.get("inst_count", 1))
    except (KeyError, TypeError, ValueError):
        raise DatasetError(f"{path}: entries need scene_id, im_id, obj_id and inst_count; re-download it") from None
    return out


def visible_fractions(path: Path) -> dict[int, list[float]] | None:
    """``scene_gt_info.json``: im_id -> visib_fract of each gt instance (None when absent)."""
    if not path.is_file():
        return None
    data = read_json(path)
    try:
        return {int(k): [float(g.get("visib_fract", 1.0)) for g in v] for k, v in data.items()}
    except (AttributeError, TypeError, ValueError):
        raise DatasetError(f"{path}: expected {{im_id: [{{visib_fract, ...}}]}}; re-download it") from None


def continuous_symmetry_origin(entries: list[dict], near: np.ndarray) -> np.ndarray | None:
    """The point (3,) on the continuous-symmetry axes (least squares when there are several)
    closest to ``near`` (3,); model frame, mm. A spin about the axes leaves it in place. None
    without continuous symmetries."""
    if not entries:
        return None
    near = np.asarray(near, float).reshape(3)
    lines = [
        (unit3(np.asarray(e["axis"], float).reshape(3)), np.asarray(e.get("offset", (0.0, 0.0, 0.0)), float).reshape(3))
        for e in entries
    ]
    if len(lines) == 1:  # the foot of the perpendicular, in closed form (the same bits on every CPU)
        d, o = lines[0]
        return o + d * dot3(d, near - o)
    A, b = np.zeros((3, 3)), np.zeros(3)
    for d, o in lines:
        P = np.eye(3) - np.outer(d, d)  # distance of x to the line: |P (x - offset)|
        A += P
        b += apply_R(P, o)
    return near + np.linalg.lstsq(A, b - apply_R(A, near), rcond=None)[0]
