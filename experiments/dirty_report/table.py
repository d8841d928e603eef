"""The dirty-mask report's table (study: README.md): per method, @10 and BOP's AR as the mean over
seeds 0-2 [min-max] with the seeds' agreement, on the clutter report scenes (pooled and per object
half), on the shared YCB-V frames (pooled and per scene), per object, and ours' object split: each
report half against the dev half that would choose for it.

    python experiments/dirty_report/table.py RUNS OUT.md
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from functools import cache
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from sample_rows import OBJECTS  # noqa: E402

METHODS = ("ours", "icp", "ppf")
#: configs/split/clutter_objects.yaml: the object halves; fold A chooses on dev_A, reports report_B
HALF_A, HALF_B = (1, 6, 9, 12), (4, 5, 13, 14)

Keep = Callable[[dict], bool]


def runs(root: Path) -> dict[int, tuple[Path, list[dict]]]:
    """Seed -> (run directory, its rows, one per sample) of the runs under ``root``."""
    from catpose.bench.run.rundir import latest_rows

    out = {}
    for path in sorted(root.rglob("samples.jsonl")):
        seed = int(path.parent.name.split("-")[0].removeprefix("seed"))
        out[seed] = (path.parent, latest_rows(path))
    return out


def obj_of(row: dict) -> int:
    return int((row.get("info") or {}).get("obj_id", -1))


def scene_of(row: dict) -> int:
    return int((row.get("info") or {}).get("scene_id", -1))


def right(row: dict) -> bool:
    err = row.get("err_deg")
    return row.get("status") == "ok" and err is not None and err <= 10.0


@cache
def run_errors(run_dir: Path):
    """The run's per-target BOP errors (``target_errors``), read once per run for all its cells."""
    from catpose.bench.run.bop_ar import target_errors

    return target_errors(run_dir)


def ar_of(run_dir: Path, ids: set[str]) -> float:
    """BOP's AR of the run's targets among ``ids`` (as ``bench suite`` scores them)."""
    from catpose.bench.run.bop_ar import ar_scores

    errors = run_errors(run_dir)
    if errors is None or not ids:
        return float("nan")
    return float(ar_scores(errors[errors["sample_id"].isin(ids)])["ar"])


def cell(seeds: dict[int, tuple[Path, list[dict]]], keep: Keep = lambda r: True, ar: bool = True) -> str:
    """@10 (and AR) mean [min-max] over the seeds, n per seed and the seeds' agreement."""
    from sample_rows import spread

    from catpose.bench.real.suite_table import estimate, seed_agreement

    if not seeds:
        return "not run"
    rows = {s: [r for r in rs if keep(r)] for s, (_, rs) in seeds.items()}
    acc = [float(np.mean([right(r) for r in rs])) for rs in rows.values() if rs]
    agree = seed_agreement([{r["sample_id"]: estimate(r) for r in rs} for rs in rows.values()])
    n = len(next(iter(rows.values())))
    text = f"{spread(acc)}"
    if ar:
        ars = [ar_of(seeds[s][0], {r["sample_id"] for r in rs}) for s, rs in rows.items()]
        ars = [a for a in ars if a == a]  # a run off BOP-layout data has no AR
        text += f", AR {spread(ars)}" if ars else ""
    return f"{text} (n={n}, agree {agree:.2f})"


def at10_mean(seeds: dict[int, tuple[Path, list[dict]]], keep: Keep) -> float:
    return float(np.mean([np.mean([right(r) for r in rs if keep(r)]) for _, rs in seeds.values()]))


def table(cols: list[tuple[str, dict[str, dict], Keep]], ar: bool = True) -> list[str]:
    """One row per method; each column ``(title, {method: seeds}, which views)``."""
    lines = ["| method | " + " | ".join(c[0] for c in cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for m in METHODS:
        lines.append(f"| {m} | " + " | ".join(cell(runs_of.get(m, {}), keep, ar) for _, runs_of, keep in cols) + " |")
    return lines + [""]


def flagged(row: dict) -> bool:
    """Whether ``Registration.ambiguous`` flags the answer: its runner-up lost by less than
    :data:`catpose.api.result.AMBIGUOUS_MARGIN` (a sample without a runner-up is not flagged)."""
    from catpose.api.result import AMBIGUOUS_MARGIN

    margin = ((row.get("extras") or {}).get("runner_up") or {}).get("margin")
    return margin is not None and margin < AMBIGUOUS_MARGIN


def wrong_kinds(seeds: dict[int, tuple[Path, list[dict]]], objects: dict[int, str]) -> list[str]:
    """Ours' wrong answers per object, all seeds pooled: the truth held (found@10: some pose ours
    held lies within 10 deg of it) and a half turn (170 deg or more) chosen, the truth held and
    another pose chosen, or the truth never held (a search miss); and how many of them the doubt
    flag (``Registration.ambiguous``) marks, with how many answers it leaves unmarked and how many
    of those are right."""
    lines = [
        "| object | views (all seeds) | wrong | truth held, half turn chosen | truth held, other chosen | search miss"
        " | wrong and flagged ambiguous | unflagged: right of n |",
        "|---|---|---|---|---|---|---|---|",
    ]
    rows = [r for _, rs in seeds.values() for r in rs]
    for o, name in [*objects.items(), (None, "all")]:
        mine = [r for r in rows if o is None or obj_of(r) == o]
        wrong = [r for r in mine if not right(r)]
        held = [r for r in wrong if (r.get("found_err_deg") or 999.0) <= 10.0]
        half = [r for r in held if (r.get("err_deg") or 0.0) >= 170.0]
        calm = [r for r in mine if not flagged(r)]
        lines.append(
            f"| {name} | {len(mine)} | {len(wrong)} | {len(half)} | {len(held) - len(half)} | {len(wrong) - len(held)}"
            f" | {sum(flagged(r) for r in wrong)} | {sum(right(r) for r in calm)} of {len(calm)} |"
        )
    return lines + [""]


def main(argv: list[str]) -> int:
    from sample_rows import write_table

    root, out = Path(argv[0]), Path(argv[1])
    clutter = {m: runs(root / "clutter_report" / m) for m in METHODS}
    clutter_written = {m: runs(root / "written" / "clutter_report" / m) for m in METHODS}
    ycbv = {m: runs(root / "ycbv" / m) for m in METHODS}
    ycbv_written = {m: runs(root / "written" / "ycbv" / m) for m in METHODS}
    dev = runs(root / "clutter_dev" / "ours")
    every: Keep = lambda r: True  # noqa: E731
    lines = [
        "# Segmenter-like masks on the report parts (issue 58's condition)",
        "",
        f"Written by `experiments/dirty_report/table.py` from `{root}` (study: `experiments/dirty_report/README.md`).",
        "Segmenter-like masks: `dataset.mask_noise=1` (the edge dilated or eroded, blobs bleeding onto the table and",
        "the neighbours, strength drawn per instance, seeded by the run); written masks: the loaded ones",
        "(`dataset.mask_noise=0`). Own model (`gt_model`), seeds 0-2. Each cell: @10, then BOP's AR, as the mean over",
        "the seeds [min-max]; n views per seed; agree: the views whose answers under every seed lie within 10 deg of",
        "each other (`bench suite`'s). Report parts only; nothing here chose anything.",
        "",
        "## Clutter report scenes 100-199",
        "",
    ]
    lines += table(
        [
            ("written masks", clutter_written, every),
            ("segmenter-like masks", clutter, every),
            ("segmenter-like, report_A (objects 1, 6, 9, 12)", clutter, lambda r: obj_of(r) in HALF_A),
            ("segmenter-like, report_B (objects 4, 5, 13, 14)", clutter, lambda r: obj_of(r) in HALF_B),
        ]
    )
    lines += ["Per object, segmenter-like masks, @10 only:", ""]
    lines += table([(name, clutter, lambda r, o=o: obj_of(r) == o) for o, name in OBJECTS.items()], ar=False)
    lines += ["Ours' wrong answers, segmenter-like masks:", ""]
    lines += wrong_kinds(clutter["ours"], OBJECTS)
    lines += [
        "## Ours' object split: each report half against the dev half that chooses for it",
        "",
        "Fold A chooses on dev_A (dev scenes 0-99, objects 1, 6, 9, 12) and reports report_B; fold B the reverse",
        "(`configs/split/clutter_objects.yaml`). Issue 58 asks each report part within 0.03 of its choose part.",
        "",
        "| fold | choose part @10 | report part @10 | report - choose |",
        "|---|---|---|---|",
    ]
    for fold, choose, report in (("A", HALF_A, HALF_B), ("B", HALF_B, HALF_A)):
        c = at10_mean(dev, lambda r, h=choose: obj_of(r) in h) if dev else float("nan")
        r = at10_mean(clutter["ours"], lambda r, h=report: obj_of(r) in h) if clutter["ours"] else float("nan")
        lines.append(f"| {fold} | {c:.3f} | {r:.3f} | {r - c:+.3f} |")
    lines += ["", "## Shared YCB-V frames (scenes 1 and 2)", ""]
    lines += table(
        [
            ("written masks", ycbv_written, every),
            ("segmenter-like masks", ycbv, every),
            ("segmenter-like, scene 1", ycbv, lambda r: scene_of(r) == 1),
            ("segmenter-like, scene 2", ycbv, lambda r: scene_of(r) == 2),
        ]
    )
    shared = sorted({obj_of(r) for _, rs in ycbv["ours"].values() for r in rs})
    lines += ["Per object, segmenter-like masks, @10 only:", ""]
    lines += table([(OBJECTS[o], ycbv, lambda r, o=o: obj_of(r) == o) for o in shared], ar=False)
    lines += ["Ours' wrong answers, segmenter-like masks:", ""]
    lines += wrong_kinds(ycbv["ours"], {o: OBJECTS[o] for o in shared})
    return write_table(out, lines[:-1])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
