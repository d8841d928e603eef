"""The study's table (README.md) from run.py's JSON lines.

    python experiments/outside_mask/table.py RUNS_DIR OUT.md

RUNS_DIR holds one folder per source and seed (``clutter-seed0``, ``ycbv1dirty-seed1``, ...), each
with one ``<variant>.jsonl`` per variant (run.py).
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from sample_rows import HALVES, SEEDS, at10, read_rows, slug, spread, write_table  # noqa: E402  (experiments/_lib/sample_rows.py)

SOURCES = {
    "clutter": "clutter dev scenes 0-49, segmenter-like masks (dataset.mask_noise=1)",
    "clutterclean": "clutter dev scenes 0-49, the written masks",
    "ycbv1dirty": "YCB-V scene 1, segmenter-like masks (dataset.mask_noise=1)",
    "ycbv1clean": "YCB-V scene 1, the written masks",
}


def table(runs: Path, source: str, variants: dict[str, str]) -> list[str]:
    """One source's rows: per variant @10 (mean [min-max] over seeds), its paired difference from
    ``default`` (the same views of each seed), found@10, the object halves (clutter), and the
    median seconds against ``default``'s on the same views. ``variants``: name -> file stem."""
    runs_of = {v: {s: read_rows(runs / f"{source}-seed{s}" / f"{f}.jsonl") for s in SEEDS} for v, f in variants.items()}
    ref = {s: {r["sample_id"]: r for r in runs_of["default"][s]} for s in SEEDS}
    halves = source.startswith("clutter")
    head = "| variant | views per seed | @10 | vs default | found@10 |"
    head += " dev_A @10 | dev_B @10 |" if halves else ""
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for v in variants:
        seeds = {s: rows for s, rows in runs_of[v].items() if rows}
        if not seeds:
            continue
        diffs = []
        for s, rows in seeds.items():
            paired = [(r, ref[s][r["sample_id"]]) for r in rows if r["sample_id"] in ref[s]]
            if paired:
                diffs.append(at10([a for a, _ in paired]) - at10([b for _, b in paired]))
        cells = [
            v,
            ",".join(str(len(r)) for r in seeds.values()),
            spread([at10(r) for r in seeds.values()]),
            f"{np.mean(diffs):+.3f}" if diffs else "n/a",
            spread([at10(r, "found_err_deg") for r in seeds.values()]),
        ]
        if halves:
            for objs in HALVES.values():
                cells.append(spread([at10([x for x in r if x["obj_id"] in objs]) for r in seeds.values()]))
        out.append("| " + " | ".join(cells) + " |")
    return out


def changed(runs: Path, source: str, variants: dict[str, str]) -> list[str]:
    """Per variant, the views whose @10 differs from ``default``'s (seed: sample, default's error ->
    the variant's, deg)."""
    out = []
    for v, f in variants.items():
        if v == "default":
            continue
        moves = []
        for s in SEEDS:
            ref = {r["sample_id"]: r for r in read_rows(runs / f"{source}-seed{s}" / "default.jsonl")}
            for r in read_rows(runs / f"{source}-seed{s}" / f"{f}.jsonl"):
                b = ref.get(r["sample_id"])
                if b is not None and (r["err_deg"] <= 10.0) != (b["err_deg"] <= 10.0):
                    moves.append(f"{s}: {r['sample_id']} (obj {r['obj_id']}) {b['err_deg']:.0f} -> {r['err_deg']:.0f}")
        out.append(f"- {v}: " + ("; ".join(moves) if moves else "none"))
    return out


def timing(runs: Path, variants: dict[str, str]) -> list[str]:
    """Median seconds per view of each variant and of ``default`` on the same views, from the timing
    runs (every variant back to back on each problem, one process)."""
    out = ["| variant | clutter dev 0-9 (dirty), median s | vs default | YCB-V scene 1, median s | vs default |"]
    out.append("|---|---|---|---|---|")
    for v, f in variants.items():
        cells = [v]
        for folder in ("timing-clutter-seed0", "timing-ycbv1clean-seed0"):
            ref = {r["sample_id"]: r["seconds"] for r in read_rows(runs / folder / "default.jsonl")}
            mine = [
                (r["seconds"], ref[r["sample_id"]])
                for r in read_rows(runs / folder / f"{f}.jsonl")
                if r["sample_id"] in ref
            ]
            if not mine:
                cells += ["n/a", "n/a"]
                continue
            a, b = statistics.median(x for x, _ in mine), statistics.median(y for _, y in mine)
            cells += [f"{a:.3f} ({len(mine)} views)", f"{a / b - 1:+.0%}"]
        out.append("| " + " | ".join(cells) + " |")
    return out


def main(argv: list[str]) -> int:
    runs, out = Path(argv[0]), Path(argv[1])
    from run import VARIANTS  # the study's runner, beside this file

    names = {slug(v): v for v in VARIANTS}
    lines = [
        "# Ours with the observed depth just outside the mask",
        "",
        "Written by `experiments/outside_mask/table.py` (study: `experiments/outside_mask/README.md`).",
        "Dev parts only: the clutter dev scenes 0-49 and YCB-V scene 1, seeds 0-2; each cell the mean over",
        "the seeds [min-max]. @10: ours' answer within 10 deg; vs default: the variant's @10 minus ours'",
        "default's on the same views, mean over seeds; found@10: a pose within 10 deg held at some stage;",
        "dev_A / dev_B: the object halves of `configs/split/clutter_objects.yaml`.",
    ]
    for source, title in SOURCES.items():
        present = [names[p.stem] for p in sorted((runs / f"{source}-seed0").glob("*.jsonl")) if p.stem in names]
        if "default" not in present:
            continue
        variants = {v: slug(v) for v in VARIANTS if v in present}
        lines += ["", f"## {title}", "", *table(runs, source, variants)]
        if source.startswith("ycbv"):
            lines += ["", "Views whose @10 changed (seed: sample, deg):", "", *changed(runs, source, variants)]
    if (runs / "timing-clutter-seed0").is_dir():
        lines += [
            "",
            "## Seconds",
            "",
            "Ours' median seconds per view (one thread), every variant and the default back to back on each",
            "problem in one process, on two cores shared with other jobs; the variants' check is a study kernel",
            "(the ring is a dilation of the whole image), so the difference is an upper bound.",
            "",
            *timing(
                runs, {v: slug(v) for v in VARIANTS if (runs / "timing-clutter-seed0" / f"{slug(v)}.jsonl").exists()}
            ),
        ]
    return write_table(out, lines)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.exit(main(sys.argv[1:]))
