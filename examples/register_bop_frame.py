"""Register one object of one BOP frame with ``catpose.register`` and compare with the truth.

Usage::

    python examples/register_bop_frame.py DATASET_ROOT SCENE IM OBJ [--method ours] [--dataset bop] [--overlay PNG]
    python examples/register_bop_frame.py ../shared/data/bop/ycbv 1 2 5
    python examples/register_bop_frame.py ../shared/data/bop/ycbv 1 2 1 --overlay o.png

The frame (depth, ``cam_K``, the object's ``mask_visib``, ``depth_scale`` to mm) and the object's
model are read by the dataset ``bench run`` builds from ``configs/dataset/<dataset>.yaml``
(:func:`bop_instance`), and
``catpose.register`` takes the frame the way the benchmark does: the table plane fitted outside the
mask, ours' depth check against the whole image. Prints the pose in the model frame (mm), the
rotation error against the ground truth (for a rotationally symmetric object, the angle between the
symmetry axes) and the error of the object's position in the camera frame, mm; with ours, also its
runner-up (the next-best other pose it compared, ``Registration.runner_up``), its margin and error,
and one line when the answer is ambiguous (``Registration.ambiguous``: the depth image barely told
the two apart). ``--overlay PNG`` draws both on the depth image (``catpose.overlay``).
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np


def bop_instance(root: str, scene: int, im: int, obj: int, instance: int = 0, dataset: str | None = None) -> dict:
    """The ``instance``-th instance of object ``obj`` in image ``im`` of scene ``scene``, as
    ``bench run dataset=<dataset> dataset.root=<root> seed=0`` loads it: ``frame`` (the depth frame
    with the instance's mask, mm), ``template`` (the model as the loader normalises it; answers
    come back in the BOP model frame, mm), ``options`` (the config's frame settings as ``register``
    keywords), ``T_model_camera`` (4, 4) the truth, ``symmetry_axis`` (3,) model frame or None,
    ``obs_id``. ``dataset`` None: the config named like ``root``'s folder if there is one, else bop."""
    from importlib import resources
    from pathlib import Path

    from catpose.api.inputs import NormalisedTemplate
    from catpose.bench.run.config import compose_and_build
    from catpose.datasets.bop_layout import read_json
    from catpose.errors import InvalidInputError
    from catpose.geometry import apply_R, invert_T

    if dataset is None:
        known = (resources.files("catpose.configs") / "dataset" / f"{Path(root).name}.yaml").is_file()
        dataset = Path(root).name if known else "bop"
    _, ((_, ds),) = compose_and_build([f"dataset={dataset}", f"dataset.root={root}", "seed=0"], ("dataset",))
    gt_path = ds.layout.scene_gt(scene)
    entries = read_json(gt_path).get(str(im))
    if not isinstance(entries, list):
        raise InvalidInputError(f"{gt_path} has no image {im}; check scene_id and im_id")
    indices = [i for i, e in enumerate(entries) if int(e.get("obj_id", -1)) == obj]
    if len(indices) <= instance:
        shown = sorted({int(e.get("obj_id", -1)) for e in entries})
        raise InvalidInputError(
            f"image {im} of scene {scene} shows {len(indices)} instance(s) of object {obj} "
            f"(objects shown: {shown}); pick one of those"
        )
    category = ds.category_of_object(obj)
    if category is None:
        raise InvalidInputError(f"object {obj} is not in the {dataset} config's categories; use --dataset bop")
    obs_id = f"{category}/{scene:06d}/{im:06d}/{indices[instance]}"
    R, centre, scale = ds.normalisation(obj)
    axis = ds.symmetry_axis(obj, category)
    settings, bf = ds.frame_settings, ds.instance_frame(obs_id)
    return {
        "frame": bf.frame,
        "template": NormalisedTemplate(ds.instance_model(category, f"obj_{obj:06d}"), R, centre, scale),
        "options": {"max_points": settings.max_points, "plane_distance": settings.plane_distance},
        "T_model_camera": invert_T(bf.T_camera_model),
        "symmetry_axis": None if axis is None else apply_R(R.T, np.asarray(axis, float)),
        "obs_id": obs_id,
    }


def main(argv: list[str] | None = None) -> int:
    import catpose
    from catpose.errors import CatposeError

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root", help="BOP dataset folder (models/, test/)")
    ap.add_argument("scene", type=int)
    ap.add_argument("im", type=int)
    ap.add_argument("obj", type=int, help="BOP object id")
    ap.add_argument("--instance", type=int, default=0, help="which instance of OBJ in the image (default 0)")
    ap.add_argument("--method", default="ours")
    ap.add_argument(
        "--dataset",
        default=None,
        help="dataset config whose settings apply (bop, ycbv, tyol; default: the root folder's name if a config has it, else bop)",
    )
    ap.add_argument("--overlay", metavar="PNG", help="draw the answer and the runner-up on the depth image there")
    args = ap.parse_args(argv)
    try:
        inst = bop_instance(args.root, args.scene, args.im, args.obj, args.instance, args.dataset)
        with warnings.catch_warnings():  # said below, in one line, beside the runner-up's error
            warnings.filterwarnings("ignore", message="ambiguous")
            result = catpose.register(inst["frame"], inst["template"], method=args.method, **inst["options"])
    except CatposeError as e:
        print(f"register_bop_frame: error: {e}", file=sys.stderr)
        return 2
    if args.overlay:
        try:
            catpose.overlay(inst["frame"], result, inst["template"], args.overlay)
        except OSError as e:
            print(
                f"register_bop_frame: error: --overlay {args.overlay}: {e.strerror}; pass a PNG file path",
                file=sys.stderr,
            )
            return 2
    T, T_gt = result.T_template_camera, inst["T_model_camera"]
    what = "rotation error" if inst["symmetry_axis"] is None else "symmetry-axis error"
    err = _error_deg(T, T_gt, inst["symmetry_axis"])
    np.set_printoptions(precision=4, suppress=True)
    print(f"{inst['obs_id']} ({args.method}, {result.runtime_s:.2f} s, up from {result.extras['ground_source']})")
    print("T_model_camera (mm):")
    print(T)
    # where the object is: the model origin in the camera frame, t of T_camera_model = -R^T t
    position = -T[:3, :3].T @ T[:3, 3] + T_gt[:3, :3].T @ T_gt[:3, 3]
    print(f"{what}: {err:.2f} deg; object position error: {np.linalg.norm(position):.1f} mm")
    if result.runner_up is not None:
        second = _error_deg(result.runner_up, T_gt, inst["symmetry_axis"])
        print(f"runner-up: margin {result.runner_up_margin:.4f}, {what} {second:.2f} deg")
    if result.ambiguous:
        print(f"warning: {result.doubt()}")
    if args.overlay:
        print(f"overlay: {args.overlay} (answer green, runner-up magenta, mask yellow)")
    return 0


def _error_deg(T: np.ndarray, T_gt: np.ndarray, symmetry_axis: np.ndarray | None) -> float:
    """Degrees between the rotations of two poses (4, 4); for a rotationally symmetric object, between
    its ``symmetry_axis`` (3,) as each pose sees it."""
    if symmetry_axis is None:  # the geodesic angle between the rotations
        cos = (np.trace(T[:3, :3].T @ T_gt[:3, :3]) - 1.0) / 2.0
    else:
        cos = (T[:3, :3].T @ symmetry_axis) @ (T_gt[:3, :3].T @ symmetry_axis)
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


if __name__ == "__main__":
    sys.exit(main())
