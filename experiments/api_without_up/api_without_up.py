"""What ``catpose.register`` costs without ``up`` (the ground normal): one Markdown table.

Every view of a dataset under ``protocol=gt_model`` (its own model as the template) is
registered through :func:`catpose.register` with method ``ours``:

- ``up given``: the dataset's ground normal (what ``bench run`` gives ours);
- ``up=None, N hypotheses``: the search :func:`catpose.register` runs without ``up`` (ours once
  per direction of an N-point Fibonacci sphere, the best score kept);
- ``fixed guess, gravity filter off``: ``up=[0, -1, 0]`` (the image's up: right only for a
  level camera) with ``selection.gravity_max_deg=null``, what a caller without a ground normal
  might try instead;
- ``icp``: multi-start ICP, which never uses ``up``.

Errors are ``err_deg`` of :func:`catpose.bench.scoring.metrics.sample_errors` (main-axis error for
symmetric categories). Seconds are the method calls' wall-clock time per view (1 thread).

    python experiments/api_without_up/api_without_up.py --seed 0 --hypotheses 12,24,48 --out results/api/without_up_seed0.md
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np


def _samples(dataset: str, seed: int, overrides: list[str]):
    from catpose.bench.run.config import compose_and_build

    _, ((_, ds), (_, protocol)) = compose_and_build(
        [f"dataset={dataset}", "protocol=gt_model", f"seed={seed}", *overrides], ("dataset", "protocol")
    )
    return [protocol.load(ds, sid) for sid in protocol.sample_ids(ds)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="synthetic")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hypotheses", default="24", help="comma-separated hypothesis counts")
    parser.add_argument("--override", action="append", default=[], help="extra dataset overrides (dataset.root=...)")
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()

    import torch

    import catpose
    from catpose.bench.scoring.metrics import sample_errors

    torch.set_num_threads(1)
    samples = _samples(args.dataset, args.seed, args.override)[: args.limit]
    counts = [int(x) for x in args.hypotheses.split(",") if x]
    rows = [
        ("ours, up given", "ours", {"use_up": True}),
        *[(f"ours, up=None ({n} hypotheses)", "ours", {"up_hypotheses": n}) for n in counts],
        (
            "ours, fixed guess [0,-1,0], gravity filter off",
            "ours",
            {"guess": [0.0, -1.0, 0.0], "selection": {"gravity_max_deg": None}},
        ),
        ("icp (does not use up)", "icp", {}),
    ]
    # warm-up: numba kernels and the dictionary of the first template are built outside the timings
    p = samples[0].problem
    catpose.register(
        p.points_camera,
        p.template.points,
        "ours",
        p.ground_normal_camera,
        observation_normals=p.normals_camera,
        template_normals=p.template.normals,
    )
    table = []
    for label, method, how in rows:
        errs, secs = [], []
        for s in samples:
            p = s.problem
            kw = {k: v for k, v in how.items() if k not in ("use_up", "guess")}
            up = p.ground_normal_camera if how.get("use_up") else how.get("guess")
            t0 = time.perf_counter()
            r = catpose.register(
                p.points_camera,
                p.template.points,
                method,
                up,
                observation_normals=p.normals_camera,
                template_normals=p.template.normals,
                **kw,
            )
            secs.append(time.perf_counter() - t0)
            errs.append(
                sample_errors(r.T_template_camera, s.gt.T_template_camera, s.gt.symmetry_axis, s.gt.symmetries)[
                    "err_deg"
                ]
            )
        e = np.asarray(errs)
        table.append(
            f"| {label} | {len(e)} | {e.mean():.2f} | {np.median(e):.2f} | {(e <= 10).mean():.3f} | "
            f"{(e <= 30).mean():.3f} | {np.mean(secs):.2f} |"
        )
        print(table[-1], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    shown = [
        o if not o.startswith("dataset.root=") else f"dataset.root=.../{Path(o.split('=', 1)[1]).name}"
        for o in args.override
    ]  # no machine-specific paths in the results file
    where = " ".join([f"dataset={args.dataset}", f"seed={args.seed}", *shown])
    args.out.write_text(
        f"`catpose.register` without `up`: {where}, protocol=gt_model, {len(samples)} views "
        f"(written by experiments/api_without_up/api_without_up.py)\n\n"
        "| setting | views | mean err (deg) | median err (deg) | @10 | @30 | s / view |\n"
        "|---|---|---|---|---|---|---|\n" + "\n".join(table) + "\n"
    )


if __name__ == "__main__":
    main()
