"""Sharded runs: one run's samples split across jobs, merged back from files.

``bench run ... shards=N shard=I`` runs the samples ``ids[I::N]`` of the run's fixed order into
the run directory every shard shares, writing its own ``samples.shard-I-of-N.jsonl`` (rows) and
``shard-I-of-N.json`` (its ids in run order, whether it finished, its config). ``bench merge
RUNDIR`` (and ``bench table``, automatically) writes ``samples.jsonl`` from every shard's rows in
the run's own order, then the summaries: the serial run's files, bit for bit. Shards of other
configs or counts are refused (the run directory's name hashes only method, dataset, protocol and
seed, so shards run with another ``limit`` would meet in one folder: each shard records its
config less :data:`IGNORED_KEYS`, and a shard or merge of another config is refused in one line),
and a merge never drops rows it did not write."""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from catpose.bench.run.rundir import SAMPLES_FILE
from catpose.errors import ConfigError, DatasetError

_SHARD_RE = re.compile(r"^samples\.shard-(\d+)-of-(\d+)\.jsonl$")


class ShardsNotDone(DatasetError):
    """A merge before every shard has finished (not a fault: the last shard to finish merges)."""


def shard_samples_file(shard: int, shards: int) -> str:
    """File name of shard ``shard`` of ``shards``'s per-sample rows."""
    return f"samples.shard-{shard}-of-{shards}.jsonl"


def shard_lock_file(shard: int, shards: int) -> str:
    """The lock a shard holds while it writes (the run's own ``run.lock`` guards the merge)."""
    return f"run.shard-{shard}-of-{shards}.lock"


def shard_meta_file(shard: int, shards: int) -> str:
    """File name of shard ``shard`` of ``shards``'s ids and state."""
    return f"shard-{shard}-of-{shards}.json"


def parse_shard(shard: object, shards: object) -> tuple[int, int] | None:
    """``(shard, shards)`` from the run config, ``None`` for an unsharded run.

    Raises ConfigError naming the key on a bad value."""
    try:
        n = int(shards) if shards is not None else 1
    except (TypeError, ValueError):
        raise ConfigError(f"shards={shards!r} is not an integer; use shards=N with N >= 1") from None
    if n < 1:
        raise ConfigError(f"shards={n}: use shards=N with N >= 1")
    if shard is None:
        if n > 1:
            raise ConfigError(
                f"shards={n} needs shard=I (0 <= I < {n}); sweep them with: -m shards={n} shard=range({n})"
            )
        return None
    try:
        i = int(shard)
    except (TypeError, ValueError):
        raise ConfigError(f"shard={shard!r} is not an integer; use shard=I with 0 <= I < shards") from None
    if not 0 <= i < n:
        raise ConfigError(f"shard={i} is out of range for shards={n}; use 0 <= shard < {n}")
    return (i, n) if n > 1 else None


def shard_ids(ids: Sequence[str], shard: int, shards: int) -> list[str]:
    """The ids of shard ``shard`` of ``shards``: every ``shards``-th id from position ``shard``
    (strided, so each shard gets every category of an ordered list)."""
    return list(ids[shard::shards])


def write_shard_meta(
    run_dir: Path, shard: int, shards: int, ids: Sequence[str], finished: bool, config: dict | None = None
) -> None:
    """Record a shard's ids (run order), whether it went through all of them, and its config
    (:func:`comparable_config`), which merges compare."""
    from catpose import atomic

    meta = {"shard": shard, "shards": shards, "finished": finished, "sample_ids": list(ids)}
    if config is not None:
        meta["config"] = config
    atomic.write_text(Path(run_dir) / shard_meta_file(shard, shards), json.dumps(meta, default=str) + "\n")


def shard_files(run_dir: Path) -> dict[int, list[int]]:
    """``{N: [I, ...]}`` of the shard sample files in a run directory."""
    found: dict[int, list[int]] = {}
    for p in Path(run_dir).glob("samples.shard-*-of-*.jsonl"):
        m = _SHARD_RE.match(p.name)
        if m:
            found.setdefault(int(m.group(2)), []).append(int(m.group(1)))
    return {n: sorted(v) for n, v in found.items()}


def is_sharded(run_dir: Path) -> bool:
    return bool(shard_files(run_dir))


def needs_merge(run_dir: Path) -> bool:
    """Whether a run directory has shard files newer than its ``samples.jsonl``."""
    run_dir = Path(run_dir)
    files = [
        run_dir / name
        for n, idx in shard_files(run_dir).items()
        for i in idx
        for name in (shard_samples_file(i, n), shard_meta_file(i, n))
    ]
    if not files:
        return False
    merged = run_dir / SAMPLES_FILE
    if not merged.exists():
        return True
    return max(p.stat().st_mtime_ns for p in files if p.exists()) > merged.stat().st_mtime_ns


def merged_rows(run_dir: Path) -> list[dict]:
    """Every shard's rows in the run's order (see the module docstring).

    A sample missing from its shard file is taken from ``samples.jsonl`` when that has it (a
    serial run that shards resumed); still missing, the merge fails with the shard to re-run."""
    from catpose.bench.run.rundir import latest_rows

    run_dir = Path(run_dir)
    found = shard_files(run_dir)
    if len(found) != 1:
        raise DatasetError(
            f"{run_dir} holds shards of {sorted(found)} parts; keep one sharding per run directory "
            f"(delete the samples.shard-*-of-N.jsonl of the others)"
        )
    ((n, present),) = found.items()

    read = _metas(run_dir, n)
    for i in range(n):
        if i not in present or i not in read:
            raise ShardsNotDone(f"{run_dir}: shard {i} of {n} has not run; run it with shards={n} shard={i}")
    metas = [read[i] for i in range(n)]
    check_shard_configs(run_dir, metas)
    serial = {r["sample_id"]: r for r in latest_rows(run_dir / SAMPLES_FILE)}
    per_shard = []
    for i, meta in enumerate(metas):
        rows = {r["sample_id"]: r for r in latest_rows(run_dir / shard_samples_file(i, n))}
        foreign = sorted(set(rows) - set(meta["sample_ids"]))
        if foreign:  # a shard file copied over another's, or edited: its rows are not this shard's samples
            raise DatasetError(
                f"{run_dir / shard_samples_file(i, n)} holds {len(foreign)} sample(s) that shard {i} of {n} does not "
                f"list (e.g. {foreign[0]!r}); restore that file or re-run the shard (shards={n} shard={i})"
            )
        missing = [s for s in meta["sample_ids"] if s not in rows and s not in serial]
        if missing:
            raise ShardsNotDone(
                f"{run_dir}: shard {i} of {n} lacks {len(missing)} of {len(meta['sample_ids'])} samples "
                f"(e.g. {missing[0]!r}); finish it with the same command (shards={n} shard={i})"
            )
        per_shard.append([rows.get(s) or serial[s] for s in meta["sample_ids"]])
    out = []
    for j in range(max(map(len, per_shard), default=0)):
        out += [rows[j] for rows in per_shard if j < len(rows)]
    return out


def merge_run(run_dir: Path, force: bool = False):
    """Write ``samples.jsonl``, ``run.json`` and the summaries of a sharded run from its shard
    files; returns the run's summary (:func:`~catpose.bench.run.evaluate.summarize_run`).

    A ``samples.jsonl`` with samples that no shard lists (a run the merge did not make) is
    refused unless ``force`` (:mod:`catpose.bench.run.overwrite`)."""
    from catpose.bench.run.lock import RunLock

    run_dir = Path(run_dir)
    # under the run's own lock: shards finishing together merge one after the other, and a serial
    # run into the same directory never interleaves with a merge
    lock = RunLock(run_dir)
    lock.acquire()
    try:
        return _merge_locked(run_dir, force)
    finally:
        lock.release()


def _merge_locked(run_dir: Path, force: bool = False):
    from catpose import atomic
    from catpose.bench.run.evaluate import summarize_run
    from catpose.bench.run.rundir import jsonable, read_rows, write_run_json

    rows = merged_rows(run_dir)
    kept = {r["sample_id"] for r in rows}
    lost = [s for s in dict.fromkeys(r["sample_id"] for r in read_rows(run_dir / SAMPLES_FILE)) if s not in kept]
    if lost and not force:
        raise DatasetError(
            f"{run_dir / SAMPLES_FILE} holds {len(lost)} sample(s) that no shard lists (e.g. {lost[0]!r}): "
            f"a run this merge did not make; move it away, or `bench merge --force {run_dir}` to replace "
            "it with the shards' rows (those samples are dropped)"
        )
    with atomic.atomic_write(run_dir / SAMPLES_FILE) as f:
        for r in rows:
            f.write(json.dumps(jsonable(r)) + "\n")
    ((n, _),) = shard_files(run_dir).items()
    first = rows[0] if rows else {}
    meta = {k: first.get(k) for k in ("method", "dataset", "protocol", "seed")}
    meta.update(
        n_samples=len(rows), shards=n, merged_from=[shard_samples_file(i, n) for i in range(n)], output_dir=str(run_dir)
    )
    write_run_json(run_dir, meta)
    return summarize_run(run_dir)


def ensure_merged(run_dir: Path) -> None:
    """Merge a sharded run directory whose ``samples.jsonl`` is missing or older than a shard."""
    if needs_merge(run_dir):
        merge_run(run_dir)


def main(argv: list[str] | None = None) -> int:
    """``bench merge RUNDIR...``: samples.jsonl and summaries of sharded runs from their shard files."""
    ap = argparse.ArgumentParser(prog="bench merge", description=main.__doc__)
    ap.add_argument(
        "run_dirs",
        nargs="+",
        type=Path,
        help="run directories with samples.shard-I-of-N.jsonl files, or folders searched for them",
    )
    ap.add_argument(
        "--force",
        action="store_true",
        help="replace a samples.jsonl that holds samples no shard lists (they are dropped)",
    )
    args = ap.parse_args(argv)
    from catpose.bench.run.evaluate import format_summary
    from catpose.bench.run.overwrite import absolute_path

    dirs: list[Path] = []
    for d in args.run_dirs:
        if not d.is_dir():
            absolute_path(d)  # a loop of symbolic links: said as such
            raise DatasetError(
                f"{d} {'is a file' if d.exists() else 'does not exist'}; pass a run directory written by "
                "`bench run ... shards=N shard=I`"
            )
        found = [d] if is_sharded(d) else sorted({p.parent for p in d.rglob("samples.shard-*-of-*.jsonl")})
        if not found:
            raise DatasetError(f"no samples.shard-I-of-N.jsonl in or below {d}; nothing to merge")
        dirs += found
    from catpose.bench.run.overwrite import output_errors

    for d in dirs:
        with output_errors(d, "the run directory"):  # read-only or full: one line, the old files kept whole
            summary = merge_run(d, force=args.force)
        print(f"{d}: merged {', '.join(sorted(p.name for p in d.glob('samples.shard-*-of-*.jsonl')))}")
        print(format_summary(summary) + "\n")
    return 0


# ---------------------------------------------------------------------------------------------
# shards of one run are one configuration

IGNORED_KEYS = ("shard", "progress", "print_summary", "lock_timeout", "retry_failed", "output_root")
"""Run-level keys that do not change which samples a shard runs or what it records: the shard's
own index, console output, waiting for a lock, retrying failures, and the output root (one
folder, however it is spelt)."""


def comparable_config(cfg: Any) -> dict:
    """The resolved config as a plain dict, less :data:`IGNORED_KEYS` (``cfg``: a DictConfig or dict)."""
    from omegaconf import DictConfig, OmegaConf

    plain = OmegaConf.to_container(cfg, resolve=True) if isinstance(cfg, DictConfig) else dict(cfg)
    return {k: v for k, v in plain.items() if k not in IGNORED_KEYS and k != "hydra"}


def first_difference(a: Any, b: Any, where: str = "") -> str | None:
    """The first key (dotted) whose values differ, as ``key=a vs b``; None when equal."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            d = first_difference(a.get(k, "<unset>"), b.get(k, "<unset>"), f"{where}.{k}" if where else str(k))
            if d:
                return d
        return None
    if a != b:
        return f"{where or 'config'}={json.dumps(a, default=str)} vs {json.dumps(b, default=str)}"
    return None


def _metas(run_dir: Path, shards: int) -> dict[int, dict]:
    out = {}
    for i in range(shards):
        path = run_dir / shard_meta_file(i, shards)
        if path.is_file():
            try:
                out[i] = json.loads(path.read_text())
            except (OSError, json.JSONDecodeError) as e:
                raise DatasetError(
                    f"{path} is unreadable ({type(e).__name__}); re-run shard {i} with the same "
                    f"command (shards={shards} shard={i})"
                ) from None
    return out


def check_shard_start(run_dir: Path, shard: int, shards: int, config: dict) -> None:
    """Before shard ``shard`` of ``shards`` writes into ``run_dir``: refuse other shard counts and
    other configs (see the module docstring). ``config`` is :func:`comparable_config`'s."""
    other = sorted(n for n in shard_files(run_dir) if n != shards)
    if other:
        raise ConfigError(
            f"{run_dir} already holds a run in {other[0]} shards (samples.shard-*-of-{other[0]}.jsonl); "
            f"run it with shards={other[0]}, or delete those files to re-shard it"
        )
    for i, meta in _metas(run_dir, shards).items():
        if i == shard or "config" not in meta:
            continue
        diff = first_difference(meta["config"], config)
        if diff:
            raise ConfigError(
                f"{run_dir}: shard {i} of {shards} was run with another config ({diff} in this job); "
                "run every shard of a run with one config (or give this one another output_root)"
            )


def check_shard_configs(run_dir: Path, metas: list[dict]) -> None:
    """Before a merge: every shard that recorded its config recorded the same one."""
    recorded = [(i, m["config"]) for i, m in enumerate(metas) if "config" in m]
    for i, cfg in recorded[1:]:
        diff = first_difference(recorded[0][1], cfg)
        if diff:
            raise DatasetError(
                f"{run_dir}: shards {recorded[0][0]} and {i} of {len(metas)} were run with different "
                f"configs ({diff}); re-run the odd one with the others' config, or delete its files"
            )
