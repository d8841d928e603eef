"""What a run is called in a table or a legend: the method's display name, the pipeline and
descriptor of a row, and labels made unique by only what tells runs apart (protocol, dataset,
the overrides a user typed, differing config values; a run directory's hash only as a last resort).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from catpose.bench.report.runs import Run
from catpose.bench.report.tables_compare import config_key, data_of, seed_of
from catpose.bench.run.rundir import RUN_LEVEL_KEYS, SUBSET_KEYS
from catpose.errors import ConfigError

#: display names of methods outside catpose, scored from their own files (``bench score --method``);
#: catpose's own come from the method registry (:class:`catpose.methods.registry.MethodSpec`)
EXTERNAL_NAMES = {"equipose": "Equi-pose", "rpmnet": "RPM-Net"}


def display_name(method: str) -> str:
    """``icp`` -> ``ICP``: the registered method's display name, else an external one's, else itself."""
    from catpose.methods.registry import registered

    spec = registered().get(method.lower())
    return spec.display_name if spec else EXTERNAL_NAMES.get(method.lower().replace("_", ""), method)


def pipeline_label(run: Run) -> str:
    """``"Dictionary LPS"``-style group label from the method's pipeline options, or ``"-"``."""
    cfg = run.method_config
    matching = cfg.get("matching")
    if matching is None and run.method.lower().startswith("ours"):
        matching = "dictionary"  # our method always matches against the partial-template dictionary
    # baselines name their features; ours' descriptor is a config group node ({_target_: ...LPS, ...})
    descriptor = cfg.get("features") or cfg.get("descriptor")
    if isinstance(descriptor, dict):
        descriptor = str(descriptor.get("_target_", "")).rsplit(".", 1)[-1] or None
    parts = []
    if matching is not None:
        parts.append({"direct": "Direct match", "dictionary": "Dictionary"}.get(str(matching), str(matching)))
    if descriptor is not None:
        parts.append(str(descriptor).upper())
    return " ".join(parts) if parts else "-"


def without_optimisation(run: Run) -> bool:
    """Whether the method config switches the pose optimisation off (ours' ``optimiser.mode: none``,
    the ablation's SVD-only row)."""
    optimiser = run.method_config.get("optimiser")
    return isinstance(optimiser, dict) and str(optimiser.get("mode")) == "none"


def method_label(run: Run) -> str:
    """Display name of the run's method (``Ours``, ``Teaser++``, ...), marking ablations."""
    name = display_name(run.method)
    return f"{name} (w/o optimization)" if without_optimisation(run) else name


def _flat(d: Any, prefix: str = "") -> dict[str, Any]:
    """A nested config as ``{"method.descriptor": "pfh", ...}``."""
    if not isinstance(d, dict):
        return {prefix: d}
    out: dict[str, Any] = {}
    for k, v in d.items():
        out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def _overrides(run: Run) -> list[str]:
    """The command-line overrides the runner recorded beside the run (``overrides.txt``), less the
    run-level keys (:data:`~catpose.bench.run.rundir.RUN_LEVEL_KEYS`) and Hydra's own."""
    f = run.path / "overrides.txt"
    if not f.is_file():
        return []
    out = [o.strip().lstrip("+~") for o in f.read_text().splitlines() if o.strip()]
    out = [o for o in out if not (o.split("=", 1)[0] in SUBSET_KEYS and o.endswith("=null"))]
    return [o for o in out if o.split("=", 1)[0] not in RUN_LEVEL_KEYS and not o.startswith("hydra.")]


def _distinguishing(members: Sequence[Run]) -> list[list[str]]:
    """Label suffixes that tell ``members`` (runs sharing a label) apart, the fewest kinds first:
    the protocol, the dataset, the recorded overrides not shared by all, the config values that
    differ (``method.`` left out: the method is already in the label), and only when nothing else
    does, the run directory's name (which ends in a hash)."""

    def dataset(r: Run) -> str:
        d = r.config.get("dataset")
        return str(d.get("name", "?")) if isinstance(d, dict) else str(r.info.get("dataset", "?"))

    def unique(parts: list[list[str]]) -> bool:
        return len({tuple(p) for p in parts}) == len(parts)

    parts: list[list[str]] = [[] for _ in members]
    if len({r.protocol for r in members}) > 1:
        parts = [p + [r.protocol] for p, r in zip(parts, members)]
    if not unique(parts) and len({dataset(r) for r in members}) > 1:
        parts = [p + [dataset(r)] for p, r in zip(parts, members)]
    if not unique(parts):
        overrides = [[o for o in _overrides(r) if o.split("=", 1)[0] not in ("protocol", "dataset")] for r in members]
        shared = set.intersection(*(set(o) for o in overrides))
        parts = [
            p + [o.removeprefix("method.") for o in sorted(ov) if o not in shared] for p, ov in zip(parts, overrides)
        ]
    if not unique(parts):
        flats = [
            _flat({k: r.config.get(k) for k in ("method", "dataset", "protocol", "choice", "seed")}) for r in members
        ]
        keys = sorted(
            {k for f in flats for k in f if len({json.dumps(g.get(k), sort_keys=True, default=str) for g in flats}) > 1}
        )
        parts = [p + [f"{k}={f.get(k)}".removeprefix("method.") for k in keys] for p, f in zip(parts, flats)]
    if not unique(parts):
        parts = [p + [where] for p, where in zip(parts, _path_labels([r.path for r in members]))]
    return parts


def _path_labels(paths: Sequence[Path]) -> list[str]:
    """What tells run directories apart by their paths: their names (which end in a hash), or, for
    runs of one configuration under different output roots (the same name), the parts of their
    paths that differ (``A`` and ``B`` for ``A/.../seed0-default-H`` and ``B/.../seed0-default-H``)."""
    names = [p.name for p in paths]
    if len(set(names)) == len(names):
        return names
    parts = [Path(p).resolve().parts for p in paths]
    depth = max(map(len, parts))
    padded = [tuple(x) + ("",) * (depth - len(x)) for x in parts]
    differ = [k for k in range(depth) if len({x[k] for x in padded}) > 1]
    labels = ["/".join(x[k] for k in differ if x[k]) for x in padded]
    return labels if len(set(labels)) == len(labels) else [str(Path(p).resolve()) for p in paths]


def run_labels(
    runs: Sequence[Run], labels: dict[str, str] | None = None, group_of: Callable[[Run], str] = lambda r: ""
) -> list[str]:
    """One label per run (in order), unique within each row group ``group_of(run)``.

    The label is the user's (``labels``, see :func:`user_label`) or :func:`method_label`. The
    seeds of one configuration share it (one row: the mean across seeds). Runs sharing a label and
    group keep it, pooled into one row, when they have the same protocol and data and disjoint
    categories (one run per category); otherwise each gets only what distinguishes it
    (:func:`_distinguishing`), e.g. ``Ours`` and ``Ours (descriptor=pfh)``, never a hash unless
    nothing else differs. A label the user gave to one of them is kept as given (``--label
    RUN=Ours`` beside other runs of ours: ``Ours``, ``Ours (row=ours_pfh)``).
    """
    labels = labels or {}
    base = [user_label(r, labels) or method_label(r) for r in runs]
    keyed: dict[tuple[str, str], list[int]] = {}
    for i, r in enumerate(runs):
        keyed.setdefault((group_of(r), base[i]), []).append(i)
    out = list(base)
    for idx in keyed.values():
        seeds_of = _seeds_of_one_config(runs, idx)  # each configuration's seeds: one row, told apart as one
        idx = list(seeds_of)
        members = [runs[i] for i in idx]
        cats = [set(r.samples["category"].astype(str)) if len(r.samples) else set() for r in members]
        if len(members) == 1 or (
            sum(map(len, cats)) == len(set().union(*cats))
            and len({r.protocol for r in members}) == 1
            and len({data_of(r) for r in members}) == 1
        ):
            continue
        given = [i for i in idx if user_label(runs[i], labels)]
        for i, extra in zip(idx, _distinguishing(members)):
            if given == [i]:  # the one run the user named keeps that name; the others are told apart from it
                continue
            for j in seeds_of[i]:
                out[j] = f"{base[i]} ({', '.join(extra)})" if extra else base[i]
    return out


def _seeds_of_one_config(runs: Sequence[Run], idx: Sequence[int]) -> dict[int, list[int]]:
    """``idx`` grouped by configuration (:func:`~catpose.bench.report.tables_compare.config_key`):
    the first run of each configuration -> its runs, when their seeds differ (the seeds of one
    configuration pool into one row); a configuration with a seed twice (one run under two output
    roots) keeps each run apart."""
    by_config: dict[str, list[int]] = {}
    for i in idx:
        by_config.setdefault(config_key(runs[i]), []).append(i)
    out: dict[int, list[int]] = {}
    for members in by_config.values():
        seeds = [seed_of(runs[i]) for i in members]
        if len(set(seeds)) == len(seeds):
            out[members[0]] = members
        else:
            out.update({i: [i] for i in members})
    return dict(sorted(out.items()))


def template_count(run: Run) -> str:
    """Number of templates per view of a templates run (from the rows, else the config)."""
    s = run.samples
    if run.protocol == "templates" and len(s) and "group_id" in s:
        return str(int(s.groupby("group_id").size().max()))
    p = run.config.get("protocol") if isinstance(run.config.get("protocol"), dict) else {}
    return str(p.get("max_templates") or ("1" if run.protocol != "templates" else "?"))


def user_label(run: Run, labels: dict[str, str]) -> str | None:
    """The label given for ``run`` (by its path as given, resolved, or its folder name)."""
    return labels.get(str(run.path)) or labels.get(str(run.path.resolve())) or labels.get(run.path.name)


def parse_labels(items: Sequence[str], runs: Sequence[Run] | None = None) -> dict[str, str]:
    """``["runs/a=Ours (LPS)", ...]`` -> ``{"runs/a": "Ours (LPS)"}``.

    Run directories contain ``=`` (``seed0-method.lr=0.01-<hash>``), labels rarely do, so the
    item is split at its last ``=``. With ``runs``, an item whose RUN_DIR names none of them (by
    path, resolved path or folder name) and no folder is a :class:`ConfigError`: a label holding
    ``=`` would otherwise be dropped without a word."""
    names = {n for r in runs or () for n in (str(r.path), str(r.path.resolve()), r.path.name)}
    out = {}
    for item in items:
        key, sep, value = item.rpartition("=")
        if runs is not None and not (key in names or str(Path(key).resolve()) in names or Path(key).is_dir()):
            raise ConfigError(
                f"--label {item!r}: {key!r} is none of the runs; write --label RUN_DIR=LABEL with a run "
                "directory of the table (the item is split at its last '=', so a label may hold none)"
            )
        if not sep or not value:
            raise ConfigError(f"--label {item!r} must be RUN_DIR=LABEL")
        out[str(Path(key))] = value
        out[str(Path(key).resolve())] = value  # the same run however its path is spelled
    return out
