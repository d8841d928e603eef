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

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

S, R = "method.selection.", "method.resting."
#: name -> Hydra overrides of ours' keys (README.md: the order they ran in, likeliest removable first)
VARIANTS = {
    "default": (),
    "depth_min_inliers 0": (S + "depth_min_inliers=0",),
    "depth_fit_erode_px 0": (S + "depth_fit_erode_px=0",),
    # experiments/poor_fit: the poor-fit test at a fraction a mask's bleed trips less often
    "depth_min_inliers 0.9": (S + "depth_min_inliers=0.9",),
    "depth_min_inliers 0.85": (S + "depth_min_inliers=0.85",),
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


def main(argv: list[str]) -> int:
    from sample_rows import build, variant_rows

    from catpose.bench.run.config import compose_and_build

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
    variant_rows(out_dir, seed, names, dataset, protocol, methods.__getitem__)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
