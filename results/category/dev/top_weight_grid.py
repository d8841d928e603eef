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


def gap(samples, weight: float) -> float:
    """The chosen mean error less the oracle's (degrees) over the views of ``samples`` (one
    template run's rows) when ``cross_top`` weighs the top offset ``weight``."""
    import pandas as pd

    from catpose.bench.protocols.absolute import Templates
    from catpose.bench.protocols.template_choice import choose_row
    from catpose.bench.report.category_table import row_errors

    chosen = pd.DataFrame([choose_row(g, "cross_top", top_weight=weight) for _, g in samples.groupby("group_id")])
    oracle = Templates(choice="cross").best_per_view(samples)["oracle_err_deg"].to_numpy(float)
    return float(row_errors(chosen).mean() - oracle.mean())


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
            gaps.setdefault(run.method, []).append([gap(samples, w) for w in WEIGHTS])
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
