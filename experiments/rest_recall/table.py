"""The rest-recall table (study: README.md) from ``rest_recall.py``'s JSON lines, one file per seed:

    python experiments/rest_recall/table.py OUT.md LABEL "SOURCE=GLOB" ["SOURCE=GLOB" ...]

Per source: @10, found@10 (the truth within 10 deg of some pose ours held) and the answer's rest
per seed, the seeds' agreement, then per object and rest class of the truth the same figures over
the seeds (mean, [min-max] where the seeds differ), and every view some seed never found.
"""

from __future__ import annotations

import glob
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from sample_rows import OBJECTS  # noqa: E402

FOUND_DEG = 10.0


def spread(values: list[float]) -> str:
    """``mean`` or ``mean [min-max]`` of per-seed fractions."""
    v = np.asarray(values, float)
    if v.size == 0:
        return "-"
    if np.ptp(v) < 1e-9:
        return f"{v.mean():.3f}"
    return f"{v.mean():.3f} [{v.min():.3f}-{v.max():.3f}]"


def load(pattern: str) -> dict[int, list[dict]]:
    """seed -> rows of the files matching ``pattern`` (one file per seed)."""
    out: dict[int, list[dict]] = defaultdict(list)
    for path in sorted(glob.glob(pattern)):
        for line in Path(path).read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                out[int(r["seed"])].append(r)
    return dict(sorted(out.items()))


def agreement(per_seed: dict[int, list[dict]]) -> float:
    from catpose.bench.real.suite_table import estimate, seed_agreement

    return seed_agreement([{r["sample_id"]: estimate(r) for r in rows} for rows in per_seed.values()])


def section(name: str, per_seed: dict[int, list[dict]]) -> list[str]:
    seeds = list(per_seed)
    lines = [f"## {name}", ""]
    if not seeds:
        return [*lines, "(no runs)", ""]

    def frac(rows, key):
        return float(np.mean([key(r) for r in rows])) if rows else float("nan")

    ok = lambda r: r["err_deg"] <= FOUND_DEG  # noqa: E731
    found = lambda r: r["found_err_deg"] <= FOUND_DEG  # noqa: E731
    in_rest = lambda r: r["answer_rest"] == r["truth_rest"]  # noqa: E731
    n = {s: len(rows) for s, rows in per_seed.items()}
    lines += [
        f"Seeds {', '.join(map(str, seeds))}; {' / '.join(str(n[s]) for s in seeds)} views. "
        f"Seeds agree on {agreement(per_seed):.3f} of the views.",
        "",
        "| | " + " | ".join(f"seed {s}" for s in seeds) + " | mean [min-max] |",
        "|---|" + "---|" * (len(seeds) + 1),
    ]
    for label, key in (("@10", ok), ("found@10", found), ("answer in the truth's rest", in_rest)):
        v = [frac(per_seed[s], key) for s in seeds]
        lines.append(f"| {label} | " + " | ".join(f"{x:.3f}" for x in v) + f" | {spread(v)} |")
    lines += [
        "",
        "Per object and rest of the truth (the model's stable rest classes, `catpose.resting.rest_classes`;"
        " p: its drop-test probability; n: views per seed; figures over the seeds):",
        "",
        "| object | rest (p) | n | found@10 | @10 | answer in the truth's rest |",
        "|---|---|---|---|---|---|",
    ]
    groups: dict[tuple, dict[int, list[dict]]] = defaultdict(lambda: defaultdict(list))
    for s, rows in per_seed.items():
        for r in rows:
            groups[(r["obj_id"], r["truth_rest"])][s].append(r)
    for (obj, rest), by_seed in sorted(groups.items(), key=lambda kv: (kv[0][0] or 0, kv[0][1])):
        any_row = next(iter(by_seed.values()))[0]
        if rest >= 0:
            info = any_row["rests"][rest]
            label = f"{info['label']} ({info['probability']:.2f})"
        else:
            label = "none (not a stable rest)"
        counts = sorted({len(v) for v in by_seed.values()})
        cells = [spread([frac(by_seed[s], key) for s in seeds if s in by_seed]) for key in (found, ok, in_rest)]
        lines.append(
            f"| {OBJECTS.get(obj, obj)} | {label} | {'/'.join(map(str, counts))} | " + " | ".join(cells) + " |"
        )
    missed: dict[str, dict[int, dict]] = defaultdict(dict)
    for s, rows in per_seed.items():
        for r in rows:
            if not found(r):
                missed[r["sample_id"]][s] = r
    lines += ["", f"Views some seed never found ({len(missed)}):", ""]
    if missed:
        lines += ["| view | object | rest of the truth | seeds (best pose held, deg) |", "|---|---|---|---|"]
        for sid, by_seed in sorted(missed.items()):
            r = next(iter(by_seed.values()))
            rest = r["rests"][r["truth_rest"]]["label"] if r["truth_rest"] >= 0 else "none"
            what = ", ".join(f"{s} ({x['found_err_deg']:.0f})" for s, x in sorted(by_seed.items()))
            lines.append(f"| `{sid}` | {OBJECTS.get(r['obj_id'], r['obj_id'])} | {rest} | {what} |")
    return [*lines, ""]


def main(argv: list[str]) -> int:
    from catpose.atomic import write_text

    out, label, sources = Path(argv[0]), argv[1], argv[2:]
    lines = [f"# Rest recall: ours ({label}), per object and resting pose", ""]
    lines += ["Written by `experiments/rest_recall/table.py` (study: `experiments/rest_recall/README.md`).", ""]
    for item in sources:
        name, pattern = item.split("=", 1)
        lines += section(name, load(pattern))
    write_text(out, "\n".join(lines))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
