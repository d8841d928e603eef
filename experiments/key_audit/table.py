"""The study's tables and each variant's verdict under the README's rule, from run.py's JSON lines.

    python experiments/key_audit/table.py RUNS_DIR OUT.md [STUDY_README]

STUDY_README: another study that ran variants with this harness (experiments/poor_fit): the header
names it and the verdict column (this study's rule of removal) is left out.

RUNS_DIR holds one folder per source and seed (``clutter-seed0``, ``ycbv1dirty-seed1``, ...), each
with one ``<variant>.jsonl`` per variant (run.py).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from sample_rows import HALVES, agreement, at10, delta, f3, load, seconds, slug, spread, write_table  # noqa: E402  (experiments/_lib/sample_rows.py)

SOURCES = {
    "clutter": "clutter dev scenes 0-49, segmenter-like masks (dataset.mask_noise=1)",
    "ycbv1dirty": "YCB-V scene 1, segmenter-like masks (dataset.mask_noise=1)",
    "ycbv1clean": "YCB-V scene 1, the written masks",
}
#: the README's rule, fixed before the runs: the two sources it reads, the margins
RULE_SOURCES, SMALL, LARGE = ("clutter", "ycbv1dirty"), 0.005, 0.01
#: variants whose key only tunes a stage another variant's verdict removes, and that variant
MOOT = {"depth_fit_erode_px 0": "depth_min_inliers 0"}


def verdict(d: dict[str, float]) -> str:
    """The README's rule on the paired differences ``d`` (source or half -> delta)."""
    c, y = (d[s] for s in RULE_SOURCES)
    if c != c or y != y:
        return "not run on both sources"
    halves = [d[h] for h in HALVES]
    if c >= -SMALL and y >= -SMALL and all(h >= -LARGE for h in halves):
        return "**drop** (earns on neither source)"
    if max(c, y) > LARGE and min(c, y) >= -SMALL:
        return "**drop** (the ablation raises a source)"
    if max(c, y) > LARGE and min(c, y) < -LARGE:
        return "keep: **conflict**"
    if min(c, y) < -LARGE:
        earned = " and ".join(n for n, v in (("clutter", c), ("YCB-V s1", y)) if v < -LARGE)
        return f"keep (earns on {earned})"
    return "keep (no rule applies: a source or half falls by less than the keep margin)"


def main(argv: list[str]) -> int:
    runs, out = Path(argv[0]), Path(argv[1])
    study = argv[2] if len(argv) > 2 else None
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from run import VARIANTS  # the study's runner, beside this file

    ref = {src: load(runs, src, "default") for src in SOURCES}
    ran = [v for v in VARIANTS if any(load(runs, src, slug(v)) for src in SOURCES)]
    lines = [
        "# Ours' keys, one at a time set to their off or simplest value" if study is None else "# Ours' variants",
        "",
        f"Written by `experiments/key_audit/table.py` from `{runs}` (study: `{study or 'experiments/key_audit/README.md'}`).",
        "Dev parts only: the clutter dev scenes 0-49 and YCB-V scene 1, seeds 0-2. Δ: the variant's @10",
        "minus ours' default's on the same views, mean over the seeds; dev_A / dev_B: the clutter object",
        "halves of `configs/split/clutter_objects.yaml`; written: YCB-V scene 1 with its written masks",
        "(reported, not in "
        + ("the rule" if study is None else "key_audit's rule")
        + "); agree: the fraction of views whose answers under seeds 0-2 lie",
        "within 10 deg of each other (`bench suite`'s), clutter / YCB-V s1 dirty.",
        "",
        "## Summary and the rule's verdict" if study is None else "## Summary (the study's rule: its README)",
        "",
        "| variant | Δ clutter dirty | Δ dev_A | Δ dev_B | Δ YCB-V s1 dirty | Δ written | agree |"
        + (" verdict |" if study is None else ""),
        "|---|---|---|---|---|---|---|" + ("---|" if study is None else ""),
    ]
    verdict_of: dict[str, str] = {}
    for v in ran:
        mine = {src: load(runs, src, slug(v)) for src in SOURCES}
        d = {src: delta(mine[src], ref[src]) for src in SOURCES}
        d.update({h: delta(mine["clutter"], ref["clutter"], objs) for h, objs in HALVES.items()})
        agree = " / ".join("n/a" if (a := agreement(mine[s])) != a else f"{a:.2f}" for s in RULE_SOURCES)
        cells = [v, *(f3(d[k]) for k in ("clutter", "dev_A", "dev_B", "ycbv1dirty", "ycbv1clean")), agree]
        if study is not None:
            pass
        elif v == "default":
            cells.append("reference")
        elif v.startswith("the "):  # a combination: the rule's verdict read on it, nothing adopted (README)
            cells.append(f"combination: {verdict(d)}")
        elif v in MOOT and verdict_of.get(MOOT[v], "").startswith("**drop**"):
            cells.append(f"moot: its stage goes with `{MOOT[v]}` (by the rule: {verdict(d)})")
        else:
            cells.append(verdict_of.setdefault(v, verdict(d)))
        lines.append("| " + " | ".join(cells) + " |")
    for src, title in SOURCES.items():
        lines += ["", f"## {title}", ""]
        head = "| variant | views per seed | @10 | Δ | found@10 | agree | median s |"
        head += " dev_A @10 | dev_B @10 |" if src == "clutter" else ""
        lines += [head, "|" + "---|" * (head.count("|") - 1)]
        for v in ran:
            mine = load(runs, src, slug(v))
            if not mine:
                continue
            a = agreement(mine)
            cells = [
                v,
                ",".join(str(len(r)) for r in mine.values()),
                spread([at10(r) for r in mine.values()]),
                f3(delta(mine, ref[src])),
                spread([at10(r, "found_err_deg") for r in mine.values()]),
                "n/a" if a != a else f"{a:.2f}",
                f"{seconds(mine):.3f}",
            ]
            if src == "clutter":
                for objs in HALVES.values():
                    cells.append(spread([at10([x for x in r if x["obj_id"] in objs]) for r in mine.values()]))
            lines.append("| " + " | ".join(cells) + " |")
    return write_table(out, lines)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
