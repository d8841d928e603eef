"""The study's table from run.py's JSON lines (README.md).

    python experiments/robust_start/table.py RUNS_DIR OUT.md [VARIANT STUDY_README]

VARIANT and STUDY_README: another study's variant against ``default`` in the same layout
(experiments/bleed_fit); by default this study's ``median start``.

RUNS_DIR holds one folder per source and seed (``clutter-seed0``, ``ycbv1clean-seed2``, ...), each
with one ``<variant>.jsonl`` per variant, and ``templates/`` (``bench run`` folders of the category
templates, ``<variant>-seed<seed>``), tabled by ``bench table`` in make.sh.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from sample_rows import HALVES, agreement, at10, delta, f3, load, seconds, slug, spread, write_table  # noqa: E402  (experiments/_lib/sample_rows.py)

SOURCES = {
    "clutter": "clutter dev scenes 0-49, segmenter-like masks (dataset.mask_noise=1)",
    "ycbv1dirty": "YCB-V scene 1, segmenter-like masks (dataset.mask_noise=1)",
    "clutterclean": "clutter dev scenes 0-49, the written masks",
    "ycbv1clean": "YCB-V scene 1, the written masks",
}
TITLES = {
    "median start": "Ours' coarse search started at the points' median",
    "bleed-aware": "Ours' poor-fit test without the mask's bleed",
}


def main(argv: list[str]) -> int:
    runs, out = Path(argv[0]), Path(argv[1])
    variant, study = (argv[2], argv[3]) if len(argv) > 3 else ("median start", "experiments/robust_start/README.md")
    lines = [
        f"# {TITLES.get(variant, variant)}",
        "",
        f"Written by `experiments/robust_start/table.py` from `{runs}` (study: `{study}`).",
        "Dev parts only, seeds 0-2. @10: mean over the seeds [min-max]; Δ: the variant's @10 minus the",
        "default's on the same views, mean over the seeds; dev_A / dev_B: the clutter object halves of",
        "`configs/split/clutter_objects.yaml`; agree: the fraction of views whose answers under seeds",
        "0-2 lie within 10 deg of each other; median s: ours' seconds per view (the variants back to",
        "back on each problem, one thread).",
    ]
    for src, title in SOURCES.items():
        ref = load(runs, src, "default")
        if not ref:
            continue
        lines += ["", f"## {title}", ""]
        head = "| variant | views per seed | @10 | Δ | found@10 | agree | median s |"
        head += " dev_A @10 (Δ) | dev_B @10 (Δ) |" if src.startswith("clutter") else ""
        lines += [head, "|" + "---|" * (head.count("|") - 1)]
        for v in ("default", variant):
            mine = load(runs, src, slug(v))
            if not mine:
                continue
            a = agreement(mine)
            cells = [
                v,
                ",".join(str(len(r)) for r in mine.values()),
                spread([at10(r) for r in mine.values()]),
                f3(delta(mine, ref)),
                spread([at10(r, "found_err_deg") for r in mine.values()]),
                "n/a" if a != a else f"{a:.2f}",
                f"{seconds(mine):.3f}",
            ]
            if src.startswith("clutter"):
                for objs in HALVES.values():
                    at = spread([at10([x for x in r if x["obj_id"] in objs]) for r in mine.values()])
                    cells.append(f"{at} ({f3(delta(mine, ref, objs))})")
            lines.append("| " + " | ".join(cells) + " |")
    return write_table(out, lines)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
