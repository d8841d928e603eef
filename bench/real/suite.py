"""``bench suite real|clutter``: every method on the shared real data (or the cluttered synthetic
set's report scenes), one table (the sets and method rows: suite_sets; the table: suite_table).

Every (set, method, seed) goes through ``bench run``'s runner, so run directories, resume and
summaries are the usual ones; the table is made from their files. A cell is the mean across
``--seeds`` (default 0, 1, 2) with the min and max; a column whose methods were scored on
different samples is refused (``--allow-mixed`` to insist). A set with a development split
(``configs/split/<name>.yaml``) gets one column per part, and a BOP-layout set BOP'19's AR
(:mod:`catpose.bench.run.bop_ar`). The sets: docs/real-scenes.md. ``bench clutter``
(:func:`clutter_main`) renders the cluttered set ahead of its suite.

    bench suite real --sets ycbv --methods ours,icp --limit 5
    bench suite clutter --parts dev,report"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from catpose.bench.real.split import load_split
from catpose.bench.real.suite_sets import (
    CLUTTER_SETS,
    METHODS,
    SEEDS,
    SETS,
    SUITES,
    MethodVariant,
    RealSet,
    missing_extra,
    skip_reason,
)
from catpose.bench.run.config import shared_data_dir
from catpose.errors import ConfigError

log = logging.getLogger(__name__)


def compose(
    real_set: RealSet,
    variant: MethodVariant,
    shared: Path,
    seed: int,
    limit: int | None,
    output_root: str,
    method_overrides: list[str] = (),
) -> tuple[object, list[str]]:
    """The resolved run config of one (set, method) pair and its command-line overrides
    (``method_overrides``: applied to ours only, for the studies' variants)."""
    from catpose.bench.run import config

    split = load_split(real_set.split) if real_set.split and real_set.parts else None
    scenes = sorted({s for p in real_set.parts for s in split.scene_ids(p)}) if split else []
    overrides = [
        f"method={variant.method}",
        f"dataset={real_set.dataset}",
        f"protocol={real_set.protocol}",
        f"seed={seed}",
        f"output_root={output_root}",
        "progress=false",
        "print_summary=false",
        *[o.replace("{shared}", str(shared)) for o in real_set.overrides],
        *([f"dataset.scenes=[{','.join(map(str, scenes))}]"] if scenes else []),  # the parts' scenes only
        *variant.overrides,
        *(method_overrides if variant.method == "ours" else []),
    ]
    if limit is not None:
        overrides.append(f"limit={limit}")
    return config.compose(overrides), overrides


def summary_row(run_dir: Path, sample_ids: list[str] | None = None) -> dict:
    """The pooled ``all`` row of a run's summary, from its files."""
    from catpose.bench.run.evaluate import summarize_run

    summary = summarize_run(run_dir, sample_ids)
    rows = summary[summary["category"] == "all"]
    return {} if len(rows) == 0 else rows.iloc[0].to_dict()


def scored_answers(run_dir: Path, rows: list[dict]) -> dict:
    """``{view (obs_id; a pair: "<view1>~<view2>"): estimate}`` of the units the run's protocol
    scores (the registration a view keeps among its templates, a pair's relative pose), what
    :func:`~catpose.bench.real.suite_table.seed_agreement` compares across seeds."""
    import pandas as pd

    from catpose.bench.real.suite_table import estimate
    from catpose.bench.run.evaluate import load_protocol, recompute_row_errors

    if not rows:
        return {}
    units = load_protocol(run_dir).score_units(pd.DataFrame([recompute_row_errors(r) for r in rows]))
    return {str(u.get("obs_id") or u["sample_id"]): estimate(u) for u in units.to_dict("records")}


def with_ar(row: dict, errors, sample_ids: list[str] | None = None) -> dict:
    """``row`` with BOP's AR and its parts (:data:`~catpose.bench.run.bop_ar.AR_KEYS`) of the
    per-target ``errors`` of ``sample_ids`` (all of them when None); ``row`` as it is without errors."""
    if errors is None or len(errors) == 0:
        return row
    from catpose.bench.run.bop_ar import ar_scores

    chosen = errors if sample_ids is None else errors[errors["sample_id"].isin(set(sample_ids))]
    return {**row, **ar_scores(chosen)} if len(chosen) else row


def run_suite(
    sets: list[str],
    methods: list[str],
    shared: Path,
    seeds: tuple[int, ...] = SEEDS,
    limit: int | None = None,
    output_root: str = "outputs/real",
    log=print,
    table_only: bool = False,
    catalogue: dict[str, RealSet] | None = None,
) -> tuple[dict, dict]:
    """Run every (set, method, seed); returns ({(set, method): summary row}, {set or method: skip
    reason}). A row pools its seeds (:func:`pool_seeds`: the mean, and min and max across seeds).
    A set with a split also gets rows ``(<set>:<part> (<role>), method)`` for each of its parts.
    With ``table_only`` nothing runs: the rows come from the run directories already written
    (finished samples only; pairs never run are left out). ``catalogue``: the sets by name
    (default :data:`SETS`, the real suite)."""
    from catpose.bench.real.suite_table import part_label, pool_seeds
    from catpose.bench.run.bop_ar import target_errors
    from catpose.bench.run.rundir import SAMPLES_FILE, latest_rows, run_dir_for
    from catpose.bench.run.runner import run

    catalogue = SETS if catalogue is None else catalogue
    per_seed: dict[tuple[str, str], list[dict]] = {}
    skipped: dict[str, str] = {}
    if not table_only:
        for m in methods:
            why = missing_extra(METHODS[m])
            if why:
                skipped[m] = why
                log(f"skipping {m}: {why}")
        methods = [m for m in methods if m not in skipped]
    for s in sets:
        why = skip_reason(catalogue[s], shared)
        if why:
            skipped[s] = why
            log(f"skipping {s}: {why}")
            continue
        for m in methods:
            for seed in seeds:
                cfg, overrides = compose(catalogue[s], METHODS[m], shared, seed, limit, output_root)
                if table_only:
                    run_dir = run_dir_for(cfg, overrides)
                    if not (run_dir / SAMPLES_FILE).is_file():
                        continue
                else:
                    log(f"{m} on {s}, seed {seed} ...")
                    run_dir = run(cfg, overrides)
                # BOP's AR: estimates of the view's own model (None unless the set is in the BOP layout);
                # not of another instance's template, nor of a relative pose
                errors = target_errors(run_dir) if catalogue[s].protocol == "gt_model" else None
                latest = latest_rows(run_dir / SAMPLES_FILE)
                ids, answers = [r["sample_id"] for r in latest], scored_answers(run_dir, latest)
                view_of = {r["sample_id"]: str(r.get("obs_id") or r["sample_id"]) for r in latest}

                def row(d: Path, chosen: list[str] | None, errors=errors, seed=seed, answers=answers) -> dict:
                    summary = summary_row(d, chosen)  # {}: nothing scored (a relative run without a pair)
                    samples = frozenset((seed, i) for i in (ids if chosen is None else chosen))
                    views = None if chosen is None else {view_of[i] for i in chosen}
                    # for the seeds' agreement: the answers scored, of the chosen views (a pair: both)
                    estimates = {k: a for k, a in answers.items() if views is None or set(k.split("~")) <= views}
                    return summary and dict(
                        with_ar(summary, errors, chosen), run_dir=str(d), samples=samples, estimates=estimates
                    )

                if whole := row(run_dir, None):
                    per_seed.setdefault((s, m), []).append(whole)
                split = load_split(catalogue[s].split) if catalogue[s].split else None
                for part in (catalogue[s].parts or tuple(split.parts)) if split else ():
                    chosen = split.row_ids(part, latest)  # a column per part of the split
                    if chosen and (part_row := row(run_dir, chosen)):
                        per_seed.setdefault((part_label(s, split, part), m), []).append(part_row)
    return {key: pool_seeds(rows) for key, rows in per_seed.items()}, skipped


def columns(results: dict, sets: list[str]) -> list[str]:
    """Table columns: each set, then its parts' columns (in the order they were added)."""
    out = []
    for s in sets:
        out.append(s)
        out += [k for k in dict.fromkeys(key for key, _ in results) if k.startswith(f"{s}:")]
    return out


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="bench suite", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "suite",
        choices=list(SUITES),
        help="real: the shared real data; clutter: the cluttered "
        "synthetic set of the real YCB-V meshes (its report scenes)",
    )
    parser.add_argument(
        "--sets",
        default=None,
        help="comma-separated subset of the suite's sets "
        f"(real: {', '.join(SETS)}; clutter: {', '.join(CLUTTER_SETS)})",
    )
    parser.add_argument(
        "--parts",
        default=None,
        help="clutter: comma-separated split parts to run (default: report; see configs/split/clutter.yaml)",
    )
    parser.add_argument("--methods", default=",".join(METHODS), help=f"comma-separated subset of {', '.join(METHODS)}")
    parser.add_argument("--limit", type=int, default=None, help="only the first N samples of each set")
    parser.add_argument(
        "--seeds",
        default=",".join(map(str, SEEDS)),
        help=f"comma-separated seeds (default {','.join(map(str, SEEDS))}); a cell is their mean, with min and max",
    )
    parser.add_argument(
        "--allow-mixed",
        action="store_true",
        help="write a column whose methods were scored on different samples (refused otherwise), said in a note",
    )
    parser.add_argument("--output-root", default=None, help="where run directories go (default outputs/<suite>)")
    parser.add_argument(
        "--table-only", action="store_true", help="run nothing: the table of the run directories already written"
    )
    parser.add_argument("--write", type=Path, default=None, help="also write the Markdown table to this file")
    parser.add_argument(
        "--objects",
        type=Path,
        default=None,
        help="also write per-object tables of every split part to this Markdown file",
    )
    parser.add_argument(
        "--headline",
        type=Path,
        default=None,
        help="also write the table of the whole sets only (no split-part columns) to this file: the README's",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace an existing --write / --objects / --headline file"
    )
    args = parser.parse_args(argv)
    from catpose.bench.run.overwrite import Output, input_runs

    inputs = input_runs([args.output_root]) if args.output_root else ()
    outs = {  # before any work (docs/file-safety.md)
        flag: Output(path, "file", inputs, args.force, flag)
        for flag, path in (("--write", args.write), ("--objects", args.objects), ("--headline", args.headline))
        if path is not None
    }

    suite_sets = SUITES[args.suite]
    if args.parts:
        from dataclasses import replace

        wanted = tuple(args.parts.split(","))
        known = {name: load_split(rs.split).parts for name, rs in suite_sets.items() if rs.split}
        unknown = sorted(set(wanted) - {p for parts in known.values() for p in parts})
        if unknown:
            raise ConfigError(
                f"bench suite {args.suite}: --parts has unknown {unknown}; the splits have "
                + "; ".join(f"{suite_sets[n].split}: {', '.join(parts)}" for n, parts in known.items())
            )
        # each set with a split runs the wanted parts it has; a set with none of them is left out
        suite_sets = {
            name: replace(rs, parts=tuple(p for p in wanted if p in known[name]))
            for name, rs in suite_sets.items()
            if not rs.split or any(p in known[name] for p in wanted)
        }
    sets = (args.sets or ",".join(suite_sets)).split(",")
    methods = args.methods.split(",")
    for name, chosen, known in (("--sets", sets, suite_sets), ("--methods", methods, METHODS)):
        bad = [c for c in chosen if c not in known]
        if bad:
            raise ConfigError(f"bench suite {args.suite}: {name} has unknown {bad}; choose from {', '.join(known)}")
    shared = shared_data_dir()
    if not shared.is_dir():
        print(f"bench suite {args.suite}: skipped: no shared real data at {shared} (set CATPOSE_SHARED_DATA)")
        return 0
    try:
        seeds = tuple(int(x) for x in args.seeds.split(","))
    except ValueError:
        raise ConfigError(f"bench suite {args.suite}: --seeds {args.seeds!r} is not comma-separated integers") from None
    results, skipped = run_suite(
        sets,
        methods,
        shared,
        seeds,
        args.limit,
        args.output_root or f"outputs/{args.suite}",
        log=log.info,
        table_only=args.table_only,
        catalogue=suite_sets,
    )
    if args.table_only and not results and any(s not in skipped for s in sets):
        raise ConfigError(
            f"bench suite {args.suite} --table-only: no run of these sets and methods under "
            f"{args.output_root or f'outputs/{args.suite}'}; pass the --output-root they were written to, or run them"
        )
    from catpose.bench.real.suite_table import format_table, mixed_samples, seeds_note

    whole_sets = [s for s in sets if s not in skipped]
    mixed = mixed_samples(results, columns(results, whole_sets), methods)
    if mixed and not args.allow_mixed:
        from catpose.errors import DatasetError

        raise DatasetError(f"{mixed}; run every method on the same samples, or pass --allow-mixed")
    notes = [seeds_note(seeds)] + ([f"Mixed (--allow-mixed): {mixed}; its methods do not compare."] if mixed else [])
    table = format_table(results, columns(results, whole_sets), methods, skipped, notes)
    print(table)
    from catpose import atomic
    from catpose.bench.real.suite_table import object_tables

    texts = {  # the headline: the whole sets only (no split-part columns)
        "--write": lambda: table,
        "--objects": lambda: object_tables(results, suite_sets, whole_sets, methods),
        "--headline": lambda: format_table(results, whole_sets, methods, skipped, notes),
    }
    for flag, out in outs.items():
        with out.writing() as path:
            atomic.write_text(path, texts[flag]() + "\n")
    return 0


def clutter_main(argv: list[str]) -> int:
    """``bench clutter``: generate the cluttered synthetic set ahead of a run and say where it is.

    The set (``dataset=clutter``, :mod:`catpose.datasets.clutter`) is also generated on first use;
    this command does it once, for the scenes of a split part or all, and prints the cache folder and
    how many instances each part has (before and after the BOP19 visibility filter).

        bench clutter                                  # all 200 scenes of the default settings
        bench clutter --part dev                       # only the scenes that choose defaults
        bench clutter dataset.sensor=realsense         # any dataset override
    """
    import inspect
    import json

    from catpose.bench.run.config import compose_and_build

    parser = argparse.ArgumentParser(
        prog="bench clutter",
        description=inspect.cleandoc(clutter_main.__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("overrides", nargs="*", help="dataset overrides, e.g. dataset.num_scenes=40")
    parser.add_argument("--part", default=None, help="only the scenes of this part of configs/split/clutter.yaml")
    args = parser.parse_args(argv)
    split = load_split("clutter")
    overrides = ["dataset=clutter", f"dataset.root={shared_data_dir() / 'bop' / 'ycbv'}", *args.overrides]
    if args.part and args.part not in split.parts:
        raise ConfigError(
            f"--part {args.part!r} is not a part of configs/split/clutter.yaml; pass one of {list(split.parts)}"
        )
    if args.part:
        overrides.append(f"dataset.scenes={split.scene_ids(args.part)}")
    _, [(_, dataset)] = compose_and_build(overrides, ["dataset"])
    ids = dataset.observation_ids()
    print(f"clutter: {dataset.root}")
    by_part = {name: len(split.sample_ids(name, ids)) for name in split.parts}
    print(json.dumps({"instances": len(ids), "filters": dataset.filters, "by_part": by_part}))
    return 0
