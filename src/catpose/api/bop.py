"""A BOP frame's instance and its object model, loaded exactly as ``bench run`` loads them, for
:func:`catpose.register` (``examples/register_bop_frame.py``; the test that the API and the
benchmark agree on every shared YCB-Video instance).

The dataset is built from ``configs/dataset/<dataset>.yaml`` by the bench's builder with
``dataset.root`` set, so the frame (raw depth, ``cam_K``, the instance's mask, ``depth_scale`` to
mm, named by its observation id and seed) and the model (normalised as the loader normalises it:
the configured model axes, the bounding-box centre moved onto a continuous-symmetry axis) are the
ones the benchmark registers; the answer comes back in the BOP model frame, millimetres.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from catpose.api.inputs import NormalisedTemplate
from catpose.depth_frame import DepthFrame
from catpose.errors import InvalidInputError
from catpose.geometry import apply_R, invert_T
from catpose.lru import LRUCache

__all__ = ["BopInstance", "bop_instance"]

#: datasets built by earlier calls (their models, normalisations and templates stay loaded)
_DATASETS: LRUCache[tuple, Any] = LRUCache(4)


@dataclass(frozen=True, eq=False)
class BopInstance:
    """One instance of a BOP frame, ready for ``catpose.register(inst.frame, inst.template,
    **inst.options)``.

    Attributes:
        frame: the depth frame with the instance's mask (mm after ``depth_scale``).
        template: the object's model as the loader normalises it; answers come back in the BOP
            model frame, mm.
        options: the dataset config's frame settings as ``register`` keywords (``max_points``,
            ``plane_distance`` in mm).
        T_model_camera: (4, 4) the ground truth, model frame, mm (``p_model = R p_camera + t``).
        symmetry_axis: (3,) the model's main axis (model frame) when it is rotationally
            symmetric (``models_info.json``), else None: compare axes then, not rotations.
        obs_id: the observation id ``bench run`` gives it (``<category>/<scene>/<image>/<gt index>``).
    """

    frame: DepthFrame
    template: NormalisedTemplate
    options: dict[str, Any]
    T_model_camera: np.ndarray
    symmetry_axis: np.ndarray | None
    obs_id: str


def bop_instance(
    root: str,
    scene_id: int,
    im_id: int,
    obj_id: int,
    *,
    instance: int = 0,
    dataset: str | None = None,
    seed: int = 0,
    options: dict[str, Any] | None = None,
) -> BopInstance:
    """The ``instance``-th instance of object ``obj_id`` in image ``im_id`` of scene ``scene_id``.

    Args:
        root: the BOP dataset folder (``models/``, ``test/``).
        dataset: the dataset config (``bop``, ``ycbv``, ``tyol``) whose model axes, categories, mask
            and plane settings apply; None: the config named like ``root``'s folder if there is one
            (``.../ycbv``: ``ycbv``, so the observation id and its seeds are ``bench run
            dataset=ycbv``'s), else ``bop``.
        seed: the run seed (``bench run seed=...``), which seeds the frame's random subsets.
        options: more options of the dataset config (``{"mask": "render"}``).

    Raises:
        InvalidInputError: no such scene, image or object (one line, with what the frame shows).
    """
    from importlib import resources
    from pathlib import Path

    from catpose.api.method_cache import build_config
    from catpose.datasets.bop_layout import read_json
    from catpose.datasets.frame_view import FrameSettings
    from catpose.errors import CatposeError

    if dataset is None:
        known = (resources.files("catpose.configs") / "dataset" / f"{Path(root).name}.yaml").is_file()
        dataset = Path(root).name if known else "bop"
    try:
        key = (dataset, str(Path(root).resolve()), int(seed), repr(sorted((options or {}).items())))
        ds = _DATASETS.get(key)
        if ds is None:
            ds = build_config("dataset", dataset, {"root": str(root), **(options or {})}, seed=int(seed))
            ds.name = dataset  # as bench run names it (run directories and sample ids use it)
            _DATASETS.put(key, ds)
        gt_path = ds.layout.scene_gt(int(scene_id))
        entries = read_json(gt_path).get(str(int(im_id)))
    except CatposeError as e:
        raise InvalidInputError(str(e)) from None
    if not isinstance(entries, list):
        raise InvalidInputError(f"{gt_path} has no image {im_id}; check scene_id and im_id")
    indices = [i for i, e in enumerate(entries) if int(e.get("obj_id", -1)) == int(obj_id)]
    if len(indices) <= instance:
        shown = sorted({int(e.get("obj_id", -1)) for e in entries})
        raise InvalidInputError(
            f"image {im_id} of scene {scene_id} shows {len(indices)} instance(s) of object {obj_id} "
            f"(objects shown: {shown}); pick one of those"
        )
    category = ds.category_of_object(int(obj_id))
    if category is None:
        raise InvalidInputError(f"object {obj_id} is not in the {dataset} config's categories; use dataset='bop'")
    obs_id = f"{category}/{int(scene_id):06d}/{int(im_id):06d}/{indices[instance]}"
    try:
        bf = ds.instance_frame(obs_id)
        R, centre, scale = ds.normalisation(int(obj_id))
        template = ds.instance_model(category, f"obj_{int(obj_id):06d}")
        axis = ds.symmetry_axis(int(obj_id), category)
    except CatposeError as e:
        raise InvalidInputError(str(e)) from None
    settings = ds.frame_settings()
    if settings != FrameSettings(max_points=settings.max_points, plane_distance=settings.plane_distance):
        raise InvalidInputError(
            f"the {dataset} config's normal_radius, plane_iterations or plane_max_points differ from "
            "catpose.register's (FrameSettings); register would not see the frame as bench run does"
        )
    return BopInstance(
        frame=bf.frame,
        template=NormalisedTemplate(template, R, centre, scale),
        options={"max_points": settings.max_points, "plane_distance": settings.plane_distance},
        T_model_camera=invert_T(bf.T_camera_model),
        symmetry_axis=None if axis is None else apply_R(R.T, np.asarray(axis, float)),
        obs_id=obs_id,
    )
