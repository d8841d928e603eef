"""What a table may put side by side: rows scored on the same samples.

Two rows compare when they were scored on the same problems: the same data (the dataset's name,
root folder and settings, less the choice of templates, categories and scenes), protocol, seeds
and samples (no ``limit``/``sample_ids`` subset on one side only, no unfinished run).
:func:`mixed_rows` says in one line what differs; ``bench table``, ``report`` and ``suite`` refuse
such a table unless ``--allow-mixed``. A configuration's seeds pool into one row (:func:`config_key`)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from catpose.bench.run.rundir import SUBSET_KEYS

#: dataset keys that choose templates, categories or scenes, or where files are cached: not the
#: observations of a sample (the sample ids tell which samples a run has)
_NOT_DATA = ("name", "_target_", "root", "seed", "categories", "scenes", "cache_dir", "generate_missing")


def data_of(run: Any) -> str:
    """The run's data: the dataset's name, its root's last two folders, and any setting that
    changes the observations (``dataset=synthetic dataset.sensor=kinect`` is not ``dataset=synthetic``)."""
    d = run.config.get("dataset")
    if not isinstance(d, dict):
        return str(run.info.get("dataset") or "?")
    name = str(d.get("name", "?"))
    if d.get("root"):
        name += f" ({'/'.join(Path(str(d['root'])).parts[-2:])})"
    settings = {k: v for k, v in d.items() if k not in _NOT_DATA and not k.startswith("template")}
    return f"{name} {json.dumps(settings, sort_keys=True, default=str)}" if settings else name


def data_name(key: str) -> str:
    """The readable part of :func:`data_of` (name and root, without the settings)."""
    return key.split(" {", 1)[0]


def seed_of(run: Any) -> int | None:
    seed = run.config.get("seed", run.info.get("seed"))
    return None if seed is None else int(seed)


def config_key(run: Any) -> str:
    """Everything a run's rows depend on but its seed: runs with one key and different seeds pool
    into one row (mean across seeds, and their spread)."""

    def strip(node: Any) -> Any:
        if isinstance(node, dict):
            return {k: strip(v) for k, v in node.items() if k != "seed"}
        return node

    cfg = run.config
    ident = {k: strip(cfg.get(k)) for k in ("method", "dataset", "protocol", "choice")}
    ident["subset"] = {k: cfg.get(k) for k in SUBSET_KEYS if cfg.get(k)}
    ident["name"] = run.method if not cfg else None  # rows written by hand: their method's name
    return json.dumps(ident, sort_keys=True, default=str)


def sample_keys(runs: Sequence[Any]) -> dict[str, frozenset]:
    """Per category (and ``all``), the samples of ``runs``: ``(data, protocol, seed, view)``; a view
    is a row's ``group_id`` (a templates view with all its templates), else its ``sample_id``."""
    out: dict[str, set] = {"all": set()}
    for run in runs:
        s = run.samples
        if len(s) == 0:
            continue
        views = s["group_id"] if "group_id" in s else s["sample_id"]
        views = views.where(views.notna(), s["sample_id"]).astype(str)
        cats = s["category"].astype(str) if "category" in s else views.map(lambda _: "?")
        head = (data_of(run), run.protocol, seed_of(run))
        for c, v in zip(cats, views):
            out.setdefault(c, set()).add((*head, v))
            out["all"].add((*head, v))
    return {c: frozenset(v) for c, v in out.items()}


def _paths(runs: Sequence[Any]) -> str:
    shown = ", ".join(str(r.path) for r in runs[:2])
    return shown + (f" and {len(runs) - 2} more" if len(runs) > 2 else "")


def _difference(a: frozenset, b: frozenset) -> str:
    """What tells two sample sets apart, the coarsest first."""
    for k, what in ((0, "dataset"), (1, "protocol"), (2, "seeds")):
        va, vb = sorted({x[k] for x in a}, key=str), sorted({x[k] for x in b}, key=str)
        if va != vb:
            show = data_name if k == 0 else str
            return f"{what} {', '.join(show(v) for v in va)} vs {', '.join(show(v) for v in vb)}"
    return f"samples: {len(a)} vs {len(b)}, {len(a ^ b)} in one only (limit=, sample_ids= or an unfinished run)"


def mixed_rows(rows: Sequence[tuple[str, Sequence[Any]]], categories: Sequence[str]) -> str | None:
    """Why the rows ``(label, runs)`` of one table do not compare (one line naming the runs and
    what differs), or None when, in each of ``categories``, every row that has it has the same
    samples and no row pools runs of different data or protocols."""
    for label, runs in rows:
        kinds = sorted({f"{data_name(data_of(r))} / {r.protocol}" for r in runs})
        if len(kinds) > 1:
            return f"row {label} pools runs of different data or protocols ({' vs '.join(kinds)}): {_paths(runs)}"
    keys = [(label, runs, sample_keys(runs)) for label, runs in rows]
    for c in categories:
        have = [(label, runs, k[c]) for label, runs, k in keys if k.get(c)]
        for label, runs, samples in have[1:]:
            label0, runs0, samples0 = have[0]
            if samples != samples0:
                where = "" if c == "all" else f" ({c})"
                return (
                    f"rows of different samples in one table{where}: {label0} ({_paths(runs0)}) and {label} "
                    f"({_paths(runs)}) differ in {_difference(samples0, samples)}"
                )
    return None


#: the end of a refusal: how to compare, or to insist
FIX = (
    "compare runs of one dataset, protocol, seeds and sample set, or pass --allow-mixed to put them in one table anyway"
)
