"""``catpose.register(DepthFrame)`` beside ``bench run`` on the shared YCB-Video frames: the same
answers, errors and seconds per view (study: README.md).

    python experiments/api_frames/api_frames.py ROOT OUT.md

``ROOT``: the BOP YCB-Video folder (``../shared/data/bop/ycbv``). For every instance the bench side
is what ``bench run method=ours dataset=ycbv seed=0`` does per sample (the protocol's problem, the
method seeded by the sample id); the API side is what a user does with the frame and the model
(the loader's depth frame and normalised model, then a :class:`catpose.Registrar` per object). Both are
scored against the truth in the object-normalised frame by the scorer of every table. Ground
truth is read here to score, never by either side.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import catpose
from catpose import atomic, kernel_threads
from catpose.bench.scoring.metrics import accuracy, rotation_error_deg, sample_errors


def rows(root: Path) -> tuple[list[dict], float, float]:
    """Per instance: its id, object, both sides' errors (degrees) and seconds; and the largest
    rotation (degrees) and translation (object unit) difference between the two sides' poses."""
    from catpose.api.inputs import NormalisedTemplate
    from catpose.bench.run.config import compose_and_build
    from catpose.bench.run.sample_run import seed_everything
    from catpose.geometry import stable_seed

    _, ((_, ds), (_, protocol), (_, method)) = compose_and_build(
        ["dataset=ycbv", f"dataset.root={root}", "method=ours", "seed=0"], ("dataset", "protocol", "method")
    )
    registrars: dict[int, catpose.Registrar] = {}
    out, worst_rot, worst_trans = [], 0.0, 0.0
    for sample_id in protocol.sample_ids(ds):
        t0 = time.perf_counter()
        sample = protocol.load(ds, sample_id)  # the frame made into a problem: the API's preparation
        t1 = time.perf_counter()
        seed_everything(stable_seed(0, sample_id))
        bench = method.register(sample.problem)
        bench_s, bench_method_s = time.perf_counter() - t0, time.perf_counter() - t1

        obj = int(sample.info["obj_id"])
        if obj not in registrars:  # the model as the loader normalises it
            model = ds.instance_model(sample_id.split("/")[0], f"obj_{obj:06d}")
            registrars[obj] = catpose.Registrar(NormalisedTemplate(model, *ds.normalisation(obj)), "ours")
        settings = ds.frame_settings
        frame = ds.instance_frame(sample_id).frame  # raw depth, cam_K, mask, depth_scale to mm
        t0 = time.perf_counter()
        api = registrars[obj](frame, max_points=settings.max_points, plane_distance=settings.plane_distance)
        api_s = time.perf_counter() - t0

        gt = sample.gt
        errs = [
            sample_errors(T, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)["err_deg"]
            for T in (bench.T_template_camera, api.T_normalised)
        ]
        worst_rot = max(worst_rot, rotation_error_deg(api.T_normalised[:3, :3], bench.T_template_camera[:3, :3]))
        worst_trans = max(worst_trans, float(np.abs(api.T_normalised[:3, 3] - bench.T_template_camera[:3, 3]).max()))
        out.append(
            {
                "id": sample_id,
                "obj": obj,
                "bench": errs[0],
                "api": errs[1],
                "bench_s": bench_s,
                "api_s": api_s,
                "bench_method_s": bench_method_s,
                "api_method_s": float(api.runtime_s),
            }
        )
    return out, worst_rot, worst_trans


def markdown(found: list[dict], worst_rot: float, worst_trans: float) -> str:
    def line(name: str, key: str) -> str:
        e = [r[key] for r in found]
        return (
            f"| {name} | {len(e)} | {np.mean(e):.2f} | {np.median(e):.2f} | {accuracy(e, 10):.3f} | "
            f"{accuracy(e, 30):.3f} | {np.median([r[key + '_s'] for r in found]):.3f} | "
            f"{np.median([r[key + '_method_s'] for r in found]):.3f} |"
        )

    same = sum(r["bench"] == r["api"] for r in found)
    return "\n".join(
        [
            "ours on the shared YCB-Video frames, `bench run` and `catpose.register(DepthFrame)` "
            "(written by experiments/api_frames/api_frames.py)",
            "",
            "| path | views | mean err (deg) | median err (deg) | @10 | @30 | median s / view, frame to pose "
            "| of them the method's |",
            "|---|---|---|---|---|---|---|---|",
            line("bench run method=ours dataset=ycbv seed=0", "bench"),
            line("catpose.register(DepthFrame), a Registrar per object", "api"),
            "",
            f"Views with the same error to the bit: {same} of {len(found)}. Largest difference between "
            f"the two poses: {worst_rot:.2e} deg, {worst_trans:.2e} (object unit) in translation. "
            f"Seconds: wall clock, this machine, one process, threads=auto ({kernel_threads.threads()} here); "
            "frame to pose "
            "holds the frame's preparation (points, normals, table plane, depth image), which "
            "`bench run` times apart (its loading) and `catpose.register` inside the call.",
            "",
        ]
    )


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: api_frames.py YCBV_ROOT OUT.md", file=sys.stderr)
        return 2
    root, out = Path(argv[0]), Path(argv[1])
    if not (root / "test").is_dir():
        print(f"{root}: no BOP test/ folder; give the YCB-Video folder (../shared/data/bop/ycbv)", file=sys.stderr)
        return 2
    found, worst_rot, worst_trans = rows(root)
    atomic.write_text(out, markdown(found, worst_rot, worst_trans))
    print(out.read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
