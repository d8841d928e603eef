"""Register one object of one BOP frame with ``catpose.register`` and compare with the truth.

Usage::

    python examples/register_bop_frame.py DATASET_ROOT SCENE IM OBJ [--method ours] [--dataset bop] [--overlay PNG]
    python examples/register_bop_frame.py ../shared/data/bop/ycbv 1 2 5
    python examples/register_bop_frame.py ../shared/data/bop/ycbv 1 2 1 --overlay o.png

The frame (depth, ``cam_K``, the object's ``mask_visib``, ``depth_scale`` to mm) and the object's
model are read as ``bench run`` reads them (:func:`catpose.api.bop.bop_instance`), and
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


def main(argv: list[str] | None = None) -> int:
    import catpose
    from catpose.api.bop import bop_instance
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
        inst = bop_instance(args.root, args.scene, args.im, args.obj, instance=args.instance, dataset=args.dataset)
        with warnings.catch_warnings():  # said below, in one line, beside the runner-up's error
            warnings.filterwarnings("ignore", message="ambiguous")
            result = catpose.register(inst.frame, inst.template, method=args.method, **inst.options)
    except CatposeError as e:
        print(f"register_bop_frame: error: {e}", file=sys.stderr)
        return 2
    if args.overlay:
        try:
            catpose.overlay(inst.frame, result, inst.template, args.overlay)
        except OSError as e:
            print(
                f"register_bop_frame: error: --overlay {args.overlay}: {e.strerror}; pass a PNG file path",
                file=sys.stderr,
            )
            return 2
    T, T_gt = result.T_template_camera, inst.T_model_camera
    what = "rotation error" if inst.symmetry_axis is None else "symmetry-axis error"
    err = _error_deg(T, T_gt, inst.symmetry_axis)
    np.set_printoptions(precision=4, suppress=True)
    print(f"{inst.obs_id} ({args.method}, {result.runtime_s:.2f} s, up from {result.extras['ground_source']})")
    print("T_model_camera (mm):")
    print(T)
    # where the object is: the model origin in the camera frame, t of T_camera_model = -R^T t
    position = -T[:3, :3].T @ T[:3, 3] + T_gt[:3, :3].T @ T_gt[:3, 3]
    print(f"{what}: {err:.2f} deg; object position error: {np.linalg.norm(position):.1f} mm")
    if result.runner_up is not None:
        second = _error_deg(result.runner_up, T_gt, inst.symmetry_axis)
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
