"""The parts of a development split in ``bench suite`` tables (docs/choosing-defaults.md).

A set with a split (``configs/split/<name>.yaml``, :mod:`catpose.bench.real.split`) runs once over the
scenes of the parts it loads; its table then has one column per part, labelled with the part's
role in the split's folds (``choose A, report B``), so the figures of scenes a choice was made on
never sit in the same cell as those of scenes it was not. Per-object rows of the same runs come
from :func:`object_rows`.
"""

from __future__ import annotations

from pathlib import Path

from catpose.bench.real.split import Split, load_split


def part_label(set_name: str, split: Split, part: str) -> str:
    """``ycbv:scene1 (choose A, report B)``."""
    return f"{set_name}:{part} ({split.role(part)})"


def part_rows(run_dir: Path, split: Split, parts: list[str], summary_row) -> dict[str, dict]:
    """``{part: the pooled summary row of the run's samples in that part}`` (parts without samples
    are left out); ``summary_row(run_dir, sample_ids)`` makes a row."""
    from catpose.bench.run.rundir import latest_rows

    path = Path(run_dir) / "samples.jsonl"
    rows = latest_rows(path) if path.is_file() else []
    out = {}
    for part in parts:
        chosen = split.row_ids(part, rows)
        if chosen:
            out[part] = summary_row(run_dir, chosen)
    return out


def scenes_override(split_name: str, parts: tuple[str, ...]) -> list[str]:
    """The ``dataset.scenes=[...]`` override that loads exactly the scenes of ``parts``."""
    if not parts:
        return []
    split = load_split(split_name)
    scenes = sorted({s for p in parts for s in split.scene_ids(p)})
    return [f"dataset.scenes=[{','.join(str(s) for s in scenes)}]"]


def object_rows(run_dirs: dict[str, Path], split: Split, part: str) -> list[dict]:
    """Per-object rows (BOP ``obj_id`` of each sample's info) of several methods' runs on ``part``:
    ``{method, obj_id, n, mean_err_deg, median_err_deg, acc10, acc30}`` and, for runs on BOP-layout
    data, ``ar`` (BOP'19's AR of the object's targets); failed samples count as 180 degrees and a
    miss, as everywhere."""
    import numpy as np

    from catpose.bench.run.bop_ar import target_errors
    from catpose.bench.run.evaluate import recompute_row_errors
    from catpose.bench.run.rundir import latest_rows
    from catpose.bench.scoring.bop_eval import metric_value

    out = []
    for method, run_dir in run_dirs.items():
        rows = [recompute_row_errors(r) for r in latest_rows(Path(run_dir) / "samples.jsonl")]
        keep = set(split.row_ids(part, rows))
        errors = target_errors(run_dir)
        if errors is not None:
            errors = errors[errors["sample_id"].isin(keep)]
        by: dict[int, list[float]] = {}
        for r in rows:
            if r["sample_id"] in keep:  # a failed sample has err_deg 180 (recompute_row_errors)
                by.setdefault(int((r.get("info") or {}).get("obj_id", -1)), []).append(float(r["err_deg"]))
        for obj_id, errs in sorted(by.items()):
            e = np.asarray(errs)
            out.append(
                {
                    "method": method,
                    "obj_id": obj_id,
                    "n": len(e),
                    "mean_err_deg": float(e.mean()),
                    "median_err_deg": float(np.median(e)),
                    "acc10": float((e < 10).mean()),
                    "acc30": float((e < 30).mean()),
                    **(
                        {"ar": metric_value(errors[errors["obj_id"] == obj_id], "ar")}
                        if errors is not None and (errors["obj_id"] == obj_id).any()
                        else {}
                    ),
                }
            )
    return out


def object_tables(results: dict, catalogue: dict, sets: list[str], methods: list[str]) -> str:
    """Markdown: for every set with a split and each of its parts, one row per object and method
    (``mean / median / @10 / @30 (n)``, and ``AR`` after @30 for BOP-layout data), from the run
    directories of ``results``."""
    lines: list[str] = []
    for s in sets:
        rs = catalogue[s]
        if not rs.split:
            continue
        split = load_split(rs.split)
        run_dirs = {m: Path(results[(s, m)]["run_dir"]) for m in methods if (s, m) in results}
        for part in rs.parts or tuple(split.parts):
            rows = object_rows(run_dirs, split, part)
            if not rows:
                continue
            objects = sorted({r["obj_id"] for r in rows})
            ar = any("ar" in r for r in rows)
            lines += [
                f"\n{part_label(s, split, part)}: mean / median / @10 / @30{' / AR' if ar else ''} (n) per object\n",
                "| method | " + " | ".join(f"obj {o}" for o in objects) + " |",
                "|---|" + "---|" * len(objects),
            ]
            for m in run_dirs:
                cells = []
                for o in objects:
                    r = next((x for x in rows if x["method"] == m and x["obj_id"] == o), None)
                    cells.append(
                        "-"
                        if r is None
                        else f"{r['mean_err_deg']:.1f} / {r['median_err_deg']:.1f} / "
                        f"{r['acc10']:.2f} / {r['acc30']:.2f}{_ar_text(r)} ({r['n']})"
                    )
                lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _ar_text(row: dict) -> str:
    """`` / AR`` of an object row with BOP's AR, else nothing."""
    return f" / {row['ar']:.2f}" if "ar" in row else ""
