"""Ours with one key of ``configs/method/ours.yaml`` set to its "off" or simplest value: one JSON
line per sample and variant (study: README.md).

    python experiments/key_audit/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [OVERRIDE ...]

Each ``VARIANT`` is a name of :data:`VARIANTS` (``default``: ours unchanged), i.e. Hydra overrides
of ours' keys; each problem is loaded once and registered by every variant in turn, into
``OUT_DIR/<variant>.jsonl``. ``OVERRIDE``s are ``bench run``'s; the problems are built and ours is
seeded per sample as ``bench run`` does (``experiments/_lib/sample_rows.py``), so ``default`` gives
the run's answers. Each line: the answer's error, found@10's best error over ours' held poses, ours'
seconds for the sample and the answer relative to the truth (``T_rel`` = T_est T_gt^-1, with the
truth's symmetries: the seeds' agreement of ``bench suite``). Finished samples already in a
variant's file are skipped.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

S, R = "method.selection.", "method.resting."
#: name -> Hydra overrides of ours' keys (README.md: the order they ran in, likeliest removable first)
VARIANTS = {
    "default": (),
    "depth_min_inliers 0": (S + "depth_min_inliers=0",),
    "depth_fit_erode_px 0": (S + "depth_fit_erode_px=0",),
    "min_probability 0": (R + "min_probability=0",),
    "grid_shift 0": (R + "grid_shift=0",),
    "grid_beam 0": (R + "grid_beam=0",),
    "grid_icp yaw": (R + "grid_icp=yaw",),
    "grid_icp full": (R + "grid_icp=full",),
    "depth_final_refine 1": (S + "depth_final_refine=1",),
    "depth_top_k 1": (S + "depth_top_k=1",),
    "depth_final_pixels 1200": (S + "depth_final_pixels=1200",),
    "depth_free_weight 0": (S + "depth_free_weight=0",),
    "depth_free_weight 1": (S + "depth_free_weight=1",),
    "gravity_max_deg null": (S + "gravity_max_deg=null",),
    "refine false": (S + "refine=false",),
    "max_poses 0": (R + "max_poses=0",),
    "grid_yaws 0": (R + "grid_yaws=0",),
    # the rule's drops, one key at a time, taken together (README.md, Choice): without and with the
    # poor-fit fallback's and the gravity filter's
    "the drops but the fallback": (R + "grid_icp=full", S + "depth_final_refine=1", S + "depth_top_k=1"),
    # the drops that earn on neither source alone (no source rises either)
    "the neutral drops": (R + "grid_icp=full", S + "depth_final_refine=1", S + "gravity_max_deg=null"),
    "the drops together": (
        S + "depth_min_inliers=0",
        R + "grid_icp=full",
        S + "depth_final_refine=1",
        S + "depth_top_k=1",
        S + "gravity_max_deg=null",
    ),
}


def slug(variant: str) -> str:
    """The file name of a variant's lines (``grid_icp yaw`` -> ``grid_icp-yaw``)."""
    return "-".join("".join(c if c.isalnum() or c in "._" else " " for c in variant).split())


def main(argv: list[str]) -> int:
    from sample_rows import answer_errors, build, done_ids, register_seeded

    from catpose.bench.run.config import compose_and_build
    from catpose.geometry import compose_T, invert_T

    out_dir, seed, names = Path(argv[0]), int(argv[1]), argv[2].split(",")
    unknown = [v for v in names if v not in VARIANTS]
    if unknown:
        raise SystemExit(f"{unknown}: not in VARIANTS ({', '.join(VARIANTS)})")
    _, first, dataset, protocol = build(seed, argv[3:])
    methods = {}
    for v in names:
        m = first if not VARIANTS[v] else compose_and_build(["method=ours", *VARIANTS[v]], ["method"])[1][0][1]
        m._features = first._features  # the same descriptor and dictionary: one feature cache for all
        methods[v] = m
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {v: out_dir / f"{slug(v)}.jsonl" for v in names}
    done = {v: done_ids(p) for v, p in paths.items()}
    t_all = time.time()
    files = {v: p.open("a") for v, p in paths.items()}
    seen = set()
    for i, sid in enumerate(protocol.sample_ids(dataset)):
        todo = [v for v in names if sid not in done[v]]
        if not todo:
            continue
        s = protocol.load(dataset, sid)
        p, gt = s.problem, s.gt
        if p.template.template_id not in seen:  # the template's caches built before any timed run
            seen.add(p.template.template_id)
            methods[todo[0]].register(p)
        k = i % len(todo)  # the variants one after the other on the same problem (paired seconds), in turns first
        for v in todo[k:] + todo[:k]:
            r, seconds = register_seeded(methods[v], p, seed, sid)
            T, err, _, found = answer_errors(r, gt)
            axis = gt.symmetry_axis
            row = {
                "sample_id": sid,
                "seed": seed,
                "category": p.category,
                "obj_id": int((s.info or {}).get("obj_id", -1)),
                "err_deg": err,
                "found_err_deg": found,
                "seconds": seconds,
                "T_rel": compose_T(T, invert_T(np.asarray(gt.T_template_camera, float))).tolist(),
                "symmetry_axis": None if axis is None else [float(x) for x in np.asarray(axis).ravel()],
                "symmetries": [np.asarray(x, float).tolist() for x in (gt.symmetries or ())],
            }
            files[v].write(json.dumps(row) + "\n")
            files[v].flush()
    for f in files.values():
        f.close()
    print(f"{out_dir} seed {seed}: done in {time.time() - t_all:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
