"""The ``cross_top`` rule's top-offset weight on the chair development runs: for each weight, each
method's chosen mean error less the oracle's, per template set and averaged over the sets.

    .venv/bin/python results/category/dev/top_weight_grid.py OUT/multirun/chair_dev_k3 \
        OUT/multirun/chair_dev_swap{0,1,2,3} --out results/category/dev/chair_dev_top_weight.md

Reads the runs' stored ``info.cross_costs`` and ``info.top_offset`` (no registration is run);
weight 0 is the ``cross`` rule. Written by results/category/dev/make_chair_dev.sh.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

WEIGHTS = (0.0, 0.025, 0.05, 0.075, 0.1, 0.15, 0.2)


def chosen_errors(samples, weight: float) -> np.ndarray:
    """(views,) the error of each view's registration with the lowest ``cross_top`` cost at
    ``weight`` (a failed registration is never chosen while another is ok; failed counts 180)."""
    import pandas as pd

    from catpose.bench.protocols.template_choice import cross_costs_of

    out = []
    for _, g in samples.groupby("group_id", sort=False):
        ok = (g["status"] == "ok").to_numpy()
        cost = np.where(ok, np.nan_to_num(np.asarray(cross_costs_of(g, top=True, top_weight=weight), float),
                                          nan=np.inf), np.inf)
        err = pd.to_numeric(g["err_deg"], errors="coerce").to_numpy(float)
        out.append(err[int(np.argmin(cost))] if ok.any() else 180.0)
    return np.asarray(out, float)


def oracle_errors(samples) -> np.ndarray:
    """(views,) the lowest error over each view's ok registrations (180 when none is ok)."""
    import pandas as pd

    err = pd.to_numeric(samples["err_deg"], errors="coerce").where(samples["status"] == "ok")
    return err.groupby(samples["group_id"], sort=False).min().fillna(180.0).to_numpy(float)


def main(argv: list[str] | None = None) -> int:
    from catpose.bench.protocols.absolute import absolute_gt_only
    from catpose.bench.report.category_table import run_dirs
    from catpose.bench.report.runs import load_run
    from catpose.atomic import write_text

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sweeps", nargs="+", help="one sweep directory per template set")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    gaps: dict[str, list[list[float]]] = {}
    for sweep in args.sweeps:
        for run in (load_run(p) for p in run_dirs([sweep])):
            samples = absolute_gt_only(run.samples)
            orc = oracle_errors(samples).mean()
            gaps.setdefault(run.method, []).append([chosen_errors(samples, w).mean() - orc for w in WEIGHTS])
    sets = len(args.sweeps)
    lines = [f"**Chair development runs: chosen mean error less the oracle's (degrees) by the top-offset "
             f"weight of `cross_top` ({sets} template sets; weight 0 is `cross`)**", "",
             "| method | weight | " + " | ".join(f"set {i + 1}" for i in range(sets)) + " | mean over sets |",
             "|---|---:|" + "---:|" * (sets + 1)]
    for method in sorted(gaps):
        g = np.asarray(gaps[method], float)
        for j, w in enumerate(WEIGHTS):
            lines.append(f"| {method} | {w:g} | " + " | ".join(f"{x:.2f}" for x in g[:, j]) + f" | {g[:, j].mean():.2f} |")
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {len(lines) - 4} rows to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
