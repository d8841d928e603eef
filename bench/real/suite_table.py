"""The tables of ``bench suite``: one row per method, one column per set and per part of its
development split (:func:`part_label`: the part's role in the split's folds, so the figures of
scenes a choice was made on never share a cell with those of scenes it was not), each cell the
mean over the seeds with their spread (:func:`pool_seeds`); a column whose methods were not
scored on the same samples is named by :func:`mixed_samples` (``bench suite`` refuses it unless
``--allow-mixed``); how often the seeds' answers agree: :func:`seed_agreement`. Per-object tables
of the split parts: :func:`object_tables`."""

from __future__ import annotations

from pathlib import Path

from catpose.bench.real.split import Split, load_split


def part_label(set_name: str, split: Split, part: str) -> str:
    """``ycbv:scene1 (choose A, report B)``."""
    return f"{set_name}:{part} ({split.role(part)})"


def pool_seeds(rows: list[dict]) -> dict:
    """One cell from the rows of several seeds: each number the mean across seeds, ``spread`` its
    (min, max), ``seeds`` how many, ``samples`` every seed's sample ids, ``agree`` the
    :func:`seed_agreement` of their ``estimates`` (when every row has them); one row as it is."""
    import numpy as np

    if len(rows) == 1:
        return rows[0]
    keys = [k for k, v in rows[0].items() if isinstance(v, (int, float)) and all(k in r for r in rows)]
    out = {k: float(np.mean([r[k] for r in rows])) for k in keys}
    out["spread"] = {k: (min(r[k] for r in rows), max(r[k] for r in rows)) for k in keys}
    out["n"] = rows[0]["n"] if all(r["n"] == rows[0]["n"] for r in rows) else out["n"]
    out["seeds"] = len(rows)
    out["samples"] = frozenset().union(*(r.get("samples", frozenset()) for r in rows))
    out["run_dir"] = rows[0].get("run_dir")
    out["run_dirs"] = [r.get("run_dir") for r in rows]
    if all("estimates" in r for r in rows):
        out["agree"] = seed_agreement([r["estimates"] for r in rows])
    return out


AGREE_DEG = 10.0
"""Two seeds' answers to a sample agree when they lie within this many degrees of each other."""


def estimate(row: dict) -> tuple | None:
    """What :func:`seed_agreement` compares of a ``samples.jsonl`` row: ``(T_est T_gt^-1 (4, 4),
    symmetry axis or None, discrete symmetries)``, None for a sample without an estimate (failed).
    The estimate is taken relative to the truth (the identity when right), so that seeds which draw
    another view of a sample (ModelNet40's, the synthetic sets') compare the same way as frames
    whose truth is fixed, where it is the angle between the estimates themselves."""
    import numpy as np

    from catpose.geometry import compose_T, invert_T

    T_est, T_gt = row.get("T_est"), row.get("T_gt")
    axis, symmetries = row.get("symmetry_axis"), row.get("symmetries")
    if row.get("status") != "ok" or not isinstance(T_est, (list, np.ndarray)):
        return None
    T_est = np.reshape(np.asarray(T_est, float), (4, 4))
    if isinstance(T_gt, (list, np.ndarray)):
        T_est = compose_T(T_est, invert_T(np.reshape(np.asarray(T_gt, float), (4, 4))))
    return (
        T_est,
        np.asarray(axis, float) if isinstance(axis, (list, np.ndarray)) else None,
        symmetries if isinstance(symmetries, (list, tuple)) else (),
    )


def seed_agreement(per_seed: list[dict[str, tuple | None]]) -> float:
    """The fraction of the samples every seed answered (``{view: estimate(unit)}`` per seed, the unit scored)
    whose estimates (relative to the truth) lie pairwise within :data:`AGREE_DEG`, by the scorer's angle
    (:func:`~catpose.bench.scoring.metrics.sample_errors` of one estimate against the other: the
    rotation's geodesic angle, the angle between the estimated main axes of a symmetric object,
    the closest of its discrete symmetries); a sample failed under some seed does not agree. NaN
    without common samples."""
    from itertools import combinations

    from catpose.bench.scoring.metrics import sample_errors

    common = set.intersection(*(set(e) for e in per_seed)) if per_seed else set()
    if not common:
        return float("nan")

    def agree(sample_id: str) -> bool:
        answers = [e[sample_id] for e in per_seed]
        if any(a is None for a in answers):
            return False
        return all(sample_errors(a[0], b[0], a[1], a[2])["err_deg"] <= AGREE_DEG for a, b in combinations(answers, 2))

    return sum(agree(i) for i in common) / len(common)


def mixed_samples(results: dict, cols: list[str], methods: list[str]) -> str | None:
    """Why a column's methods were not scored on the same samples (seeds x sample ids; one line
    naming the runs and the counts), or None."""
    for c in cols:
        have = [(m, results[(c, m)]) for m in methods if results.get((c, m)) and "samples" in results[(c, m)]]
        for m, r in have[1:]:
            m0, r0 = have[0]
            if r["samples"] != r0["samples"]:
                return (
                    f"column {c} compares different samples: {m0} ({r0.get('run_dir')}) has {len(r0['samples'])}, "
                    f"{m} ({r.get('run_dir')}) {len(r['samples'])}, {len(r0['samples'] ^ r['samples'])} in one only "
                    "(a --limit, another seed or an unfinished run)"
                )
    return None


def _with_spread(row: dict, key: str, text: str, digits: int) -> str:
    lo_hi = (row.get("spread") or {}).get(key)
    return text if lo_hi is None else f"{text} [{lo_hi[0]:.{digits}f}-{lo_hi[1]:.{digits}f}]"


def format_table(
    results: dict[tuple[str, str], dict],
    sets: list[str],
    methods: list[str],
    skipped: dict[str, str],
    notes: list[str] | None = None,
) -> str:
    """Markdown: one row per method, per set ``mean / median / @10 / found@10 / @30`` (deg; found@10:
    a hypothesis within 10 deg existed at some stage of the method's search, ``-`` for a method that
    names none) and s per registration (median), ``n`` samples (per seed, ``x S`` seeds); the best
    mean and @10 of each set in bold. A cell of several seeds is their mean, with the min and max
    of the mean, @10 (and AR) across seeds in brackets. Where the set's rows have BOP scores, a
    second column ``AR (VSD / MSSD / MSPD)`` per set, the best AR in bold. ``notes``: lines under it."""
    ar_sets = {s for s in sets if any("ar" in (results.get((s, m)) or {}) for m in methods)}
    header = ["method"]
    for s in sets:
        header.append(f"{s}: mean / med / @10 / found@10 / @30 (s)")
        if s in ar_sets:
            header.append(f"{s}: AR (VSD / MSSD / MSPD)")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    best: dict[str, tuple[float, float]] = {}
    best_ar: dict[str, float] = {}
    for s in sets:
        rows = [results[(s, m)] for m in methods if results.get((s, m))]
        if rows:
            best[s] = (min(r["mean_err_deg"] for r in rows), max(r["acc10"] for r in rows))
            best_ar[s] = max((r["ar"] for r in rows if "ar" in r), default=float("nan"))
    for m in methods:
        cells = [m]
        for s in sets:
            r = results.get((s, m))
            if not r:
                cells += ["-", "-"] if s in ar_sets else ["-"]
                continue
            mean = f"{r['mean_err_deg']:.2f}"
            acc10 = f"{r['acc10']:.3f}"
            if abs(r["mean_err_deg"] - best[s][0]) < 1e-9:
                mean = f"**{mean}**"
            if abs(r["acc10"] - best[s][1]) < 1e-9:
                acc10 = f"**{acc10}**"
            fail = f", {r['failed']:g} failed" if r.get("failed") else ""
            found = r.get("found10")
            found = "-" if found is None or found != found else f"{found:.3f}"
            seeds = f" x {r['seeds']} seeds" if r.get("seeds") else ""
            if r.get("agree") == r.get("agree") and r.get("agree") is not None:  # not NaN
                seeds += f", agree {r['agree']:.2f}"
            cells.append(
                f"{_with_spread(r, 'mean_err_deg', mean, 2)} / {r['median_err_deg']:.2f} / "
                f"{_with_spread(r, 'acc10', acc10, 3)} / {found} / {r['acc30']:.3f} "
                f"({r['median_runtime_s']:.2f}{fail}) n={int(r['n'])}{seeds}"
            )
            if s in ar_sets:
                cells.append(ar_cell(r, best_ar[s]))
        lines.append("| " + " | ".join(cells) + " |")
    lines += [f"\n{n}" for n in notes or []]
    for s, why in skipped.items():
        lines.append(f"\nskipped {s}: {why}")
    return "\n".join(lines)


def ar_cell(row: dict, best: float) -> str:
    """``AR (VSD / MSSD / MSPD)`` of a row, AR in bold when it is ``best``; ``-`` without it."""
    if "ar" not in row:
        return "-"
    ar = f"{row['ar']:.3f}"
    if abs(row["ar"] - best) < 1e-9:
        ar = f"**{ar}**"
    ar = _with_spread(row, "ar", ar, 3)
    return f"{ar} ({row['ar_vsd']:.3f} / {row['ar_mssd']:.3f} / {row['ar_mspd']:.3f})"


def seeds_note(seeds: tuple[int, ...]) -> str:
    """The line under a suite table that says what a cell is."""
    if len(seeds) == 1:
        return f"Seed {seeds[0]}; n: samples."
    return (
        f"Each cell: the mean over seeds {', '.join(map(str, seeds))} ([min-max] across the seeds of the mean, "
        "@10 and AR); n: samples per seed; agree: the fraction of samples whose estimates under every seed "
        f"lie within {AGREE_DEG:g} deg of each other (of the main axis for a symmetric object)."
    )


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
                cells = {r["obj_id"]: r for r in rows if r["method"] == m}
                texts = [
                    f"{r['mean_err_deg']:.1f} / {r['median_err_deg']:.1f} / {r['acc10']:.2f} / {r['acc30']:.2f}"
                    + (f" / {r['ar']:.2f}" if "ar" in r else "")
                    + f" ({r['n']})"
                    if (r := cells.get(o))
                    else "-"
                    for o in objects
                ]
                lines.append(f"| {m} | " + " | ".join(texts) + " |")
    return "\n".join(lines)
