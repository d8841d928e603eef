"""The upright option's table (study: README.md): per variant, YCB-V per scene and object and the
TYO-L basket, @10 as the mean over the seeds with [min-max] and the seeds' agreement.

    python experiments/upright_option/table.py RUNS OUT.md
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from sample_rows import OBJECTS as ALL_OBJECTS  # noqa: E402

VARIANTS = {"default": "ours (default)", "upright": "ours, `method.resting.max_poses=0`"}
#: YCB-V object id -> name (the shared frames' three objects)
OBJECTS = {o: name for o, name in ALL_OBJECTS.items() if o in (1, 5, 9)}


def runs(root: Path) -> dict[int, list[dict]]:
    """Seed -> the rows of the one run of each seed under ``root`` (samples.jsonl)."""
    out: dict[int, list[dict]] = {}
    for path in sorted(root.glob("*/ours/seed*/samples.jsonl")):
        seed = int(path.parent.name.split("-")[0].removeprefix("seed"))
        out[seed] = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return out


def cell(seeds: dict[int, list[dict]], keep=lambda r: True) -> str:
    """@10 mean [min-max] over the seeds, n per seed and the seeds' agreement."""
    from sample_rows import spread

    from catpose.bench.real.suite_table import estimate, seed_agreement

    rows = {s: [r for r in rs if keep(r)] for s, rs in seeds.items()}
    acc = [float(np.mean([r["err_deg"] <= 10.0 for r in rs])) for rs in rows.values() if rs]
    agree = seed_agreement([{r["sample_id"]: estimate(r) for r in rs} for rs in rows.values()])
    n = len(next(iter(rows.values()))) if rows else 0
    return f"{spread(acc)} (n={n}, agree {agree:.2f})"


def scene_of(row: dict) -> int:
    return int(row["sample_id"].split("/")[1])


def main(argv: list[str]) -> int:
    from sample_rows import write_table

    root, out = Path(argv[0]), Path(argv[1])
    sets = {"written masks": "ycbv-noise0.0", "segmenter-like masks": "ycbv-noise1.0"}
    lines = [
        "# Ours with the upright option on the shared real frames",
        "",
        f"Written by `experiments/upright_option/table.py` from `{root}` (study: `experiments/upright_option/README.md`).",
        "Each cell: @10, the mean over the seeds [min-max], n views per seed and the seeds' agreement (`bench suite`'s:",
        "the views whose answers under every seed lie within 10 deg of each other). YCB-V: seeds 0-2; scene 1 holds",
        "the master chef can (standing) and the mustard bottle, scene 2 the mustard bottle and the potted meat can",
        "(on its side in every view). TYO-L: the basket, one frame, seeds 0-4; its errors per seed in degrees.",
        "",
    ]
    for label, name in sets.items():
        cols = ["YCB-V", "scene 1", "scene 2", *OBJECTS.values()]
        lines += [f"## YCB-V, {label}", "", "| variant | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
        for v, title in VARIANTS.items():
            seeds = runs(root / v / name)
            cells = [cell(seeds), cell(seeds, lambda r: scene_of(r) == 1), cell(seeds, lambda r: scene_of(r) == 2)]
            cells += [cell(seeds, lambda r, o=o: int(r["instance_id"].split("_")[-1]) == o) for o in OBJECTS]
            lines.append(f"| {title} | " + " | ".join(cells) + " |")
        lines.append("")
    lines += [
        "## TYO-L basket (`dataset=bop`), seeds 0-4",
        "",
        "| variant | @10 | errors (deg) per seed |",
        "|---|---|---|",
    ]
    for v, title in VARIANTS.items():
        seeds = runs(root / v / "tyol")
        errs = [seeds[s][0]["err_deg"] for s in sorted(seeds)]
        lines.append(f"| {title} | {np.mean([e <= 10 for e in errs]):.3f} | {', '.join(f'{e:.1f}' for e in errs)} |")
    return write_table(out, lines)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
