"""One row per setting of ours from ``rest_recall.py``'s JSON lines (study: README.md): @10,
found@10 and the answer in the truth's rest per seed (mean [min-max]), the seeds' agreement and
the median seconds, on the samples every setting ran (the first setting is the reference):

    python experiments/rest_recall/variants.py OUT.md TITLE "LABEL=GLOB" ["LABEL=GLOB" ...]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from table import FOUND_DEG, OBJECTS, agreement, load, spread  # noqa: E402


def main(argv: list[str]) -> int:
    from catpose.atomic import write_text

    out, title, items = Path(argv[0]), argv[1], argv[2:]
    runs = {label: load(pattern) for label, pattern in (i.split("=", 1) for i in items)}
    seeds = sorted(set.intersection(*(set(r) for r in runs.values())))
    common = {s: set.intersection(*({r["sample_id"] for r in run[s]} for run in runs.values())) for s in seeds}
    objs = sorted({r["obj_id"] for run in runs.values() for s in seeds for r in run[s]})
    lines = [
        f"# {title}",
        "",
        "Written by `experiments/rest_recall/variants.py` (study: `experiments/rest_recall/README.md`). "
        f"Seeds {', '.join(map(str, seeds))}; {' / '.join(str(len(common[s])) for s in seeds)} views per seed; "
        "each cell the mean over the seeds [min-max]; per object @10 / found@10 (seed means).",
        "",
        "| setting | @10 | found@10 | answer in the truth's rest | agree | median s | "
        + " | ".join(OBJECTS.get(o, str(o)) for o in objs)
        + " |",
        "|---|---|---|---|---|---|" + "---|" * len(objs),
    ]
    for label, run in runs.items():
        rows = {s: [r for r in run[s] if r["sample_id"] in common[s]] for s in seeds}
        cells = []
        for key in (
            lambda r: r["err_deg"] <= FOUND_DEG,
            lambda r: r["found_err_deg"] <= FOUND_DEG,
            lambda r: r["answer_rest"] == r["truth_rest"],
        ):
            cells.append(spread([float(np.mean([key(r) for r in rows[s]])) for s in seeds]))
        cells.append(f"{agreement(rows):.3f}")
        cells.append(f"{np.median([r['runtime_s'] for s in seeds for r in rows[s]]):.3f}")
        for o in objs:
            mine = [r for s in seeds for r in rows[s] if r["obj_id"] == o]
            acc = np.mean([r["err_deg"] <= FOUND_DEG for r in mine])
            found = np.mean([r["found_err_deg"] <= FOUND_DEG for r in mine])
            cells.append(f"{acc:.2f} / {found:.2f}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    write_text(out, "\n".join([*lines, ""]))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
