"""Shards of one run are one configuration: the checks that keep them so.

The shards of a run share its directory, whose name only hashes the method, dataset, protocol
and seed (``limit``, ``sample_ids``, ``batch``, ``threads`` ... are left out of it, so that a
limited run resumes into the full one). Two shards run with another ``limit`` would therefore
meet in one folder and merge into a run that is neither. Each shard records its full resolved
config (less the keys in :data:`IGNORED_KEYS`) in its ``shard-I-of-N.json``; a shard that starts
into a folder whose other shards were run with another config, or with another number of
shards, is refused in one line, and so is a merge of shards whose configs differ.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from catpose.errors import ConfigError, DatasetError

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
    from catpose.bench.run.merge import shard_meta_file

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
    from catpose.bench.run.merge import shard_files

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
