"""``bench run`` (Hydra) and ``bench evaluate``."""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from pathlib import Path

from catpose.errors import CatposeError, ConfigError

_GROUPS = ("method", "dataset", "protocol")
# hydra/launcher option -> the plugin package it needs (the cluster extra, `make cluster`)
_LAUNCHER_PLUGINS = {"joblib": "hydra_joblib_launcher", "local_procs": "hydra_joblib_launcher",
                     "submitit_local": "hydra_submitit_launcher", "submitit_slurm": "hydra_submitit_launcher",
                     "slurm": "hydra_submitit_launcher", "ray": "hydra_ray_launcher",
                     "ray_local": "hydra_ray_launcher"}


def available(group: str) -> list[str]:
    """Config names of a group (``configs/<group>/*.yaml``), read from the installed package."""
    root = resources.files("catpose.configs") / group
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".yaml"))


def check_overrides(argv: list[str]) -> None:
    """Fail fast, in one line, on an unknown method, dataset or protocol name."""
    for arg in argv:
        key, sep, value = arg.partition("=")
        key = key.lstrip("+~")
        if not sep or key not in _GROUPS:
            continue
        names = available(key)
        for v in value.split(","):
            if v and v not in names:
                raise ConfigError(f"unknown {key} {v!r}; available: {', '.join(names)} "
                                  f"(add configs/{key}/{v}.yaml to plug in a new one)")


def check_launcher(argv: list[str]) -> None:
    """Fail fast, in one line, on a launcher whose Hydra plugin is not installed."""
    import importlib.util

    for arg in argv:
        key, sep, value = arg.partition("=")
        if key.lstrip("+~") != "hydra/launcher" or not sep or value == "basic":
            continue
        plugin = _LAUNCHER_PLUGINS.get(value)
        if plugin is None:
            raise ConfigError(f"unknown hydra/launcher {value!r}; use one of basic, {', '.join(_LAUNCHER_PLUGINS)}")
        try:
            found = importlib.util.find_spec(f"hydra_plugins.{plugin}") is not None
        except ImportError:
            found = False
        if not found:
            raise ConfigError(f"hydra/launcher={value} needs {plugin.replace('_', '-')}, which is not installed; "
                              f"install the launchers with `make cluster` (pip install -e \".[cluster]\")")


def check_composition(argv: list[str]) -> None:
    """Fail fast, in one line, on an override that does not fit the config (a key that does not
    exist, such as a misspelt ``datset=...`` or ``method.foo=1`` without ``+``; broken override
    syntax) instead of Hydra's multi-line report. Single runs only: a sweep (``-m``) or an
    experiment is left to Hydra, which composes what this check cannot (sweep values, hydra keys)."""
    if any(a in ("-m", "--multirun") for a in argv):
        return
    overrides = [a for a in argv if not a.startswith("-")]
    if any(a.lstrip("+~").startswith(("hydra", "experiment")) for a in overrides):
        return
    from hydra import compose, initialize_config_module
    from hydra.errors import ConfigCompositionException, OverrideParseException

    try:
        with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
            compose(config_name="run", overrides=overrides)
    except (ConfigCompositionException, OverrideParseException) as e:
        parts = [str(e)] + ([str(e.__cause__).splitlines()[0]] if e.__cause__ is not None else [])
        lines = [ln.strip().rstrip(".") for p in parts for ln in p.splitlines()
                 if ln.strip() and not ln.startswith(("See https://", "Set the environment"))]
        raise ConfigError("; ".join(lines) + " (bench run --help lists the common keys)") from None


def main(argv: list[str]) -> int:
    if any(a in ("-h", "--help") for a in argv):
        print(__doc_run__)
        return 0
    check_overrides(argv)
    check_launcher(argv)
    check_composition(argv)
    import hydra
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    @hydra.main(version_base="1.3", config_path="pkg://catpose.configs", config_name="run")
    def _job(cfg) -> dict:
        from catpose.bench.run.runner import run
        from catpose.errors import RunAborted

        hc = HydraConfig.get()
        try:
            out = run(cfg, list(hc.overrides.task))
        except RunAborted as e:  # not this job's fault (disk full, broken install): stop the sweep too
            print(f"bench run: error: {e}", file=sys.stderr)
            raise SystemExit(2) from None
        except CatposeError as e:
            # one line, not Hydra's report; a sweep goes on with its other jobs, and the job's
            # status reaches the parent through <sweep dir>/<job>/job.json (bench/run/sweep.py)
            if hc.mode == RunMode.MULTIRUN:
                print(f"bench run: error in job {list(hc.overrides.task)}: {e}", file=sys.stderr)
                return {"status": "failed", "error": str(e)}
            print(f"bench run: error: {e}", file=sys.stderr)
            raise SystemExit(2) from None
        return {"status": "ok", "run_dir": str(Path(out).resolve()), "label": cfg.get("label")}

    from catpose.bench.run import sweep

    sweep.last_sweep.clear()
    saved = sys.argv
    sys.argv = ["bench run", *argv]
    try:
        _job()
    finally:
        sys.argv = saved
    return 2 if sweep.last_sweep.get("failed") else 0


__doc_run__ = """usage: bench run [-m] [KEY=VALUE ...]

Run a method over every sample of a dataset under a protocol (Hydra overrides).

  method=NAME      one of configs/method/*.yaml (icp, ours, fgr, ransac, teaser, ...)
  dataset=NAME     one of configs/dataset/*.yaml (synthetic, modelnet40, bop, redwood, ...)
  protocol=NAME    gt_model | templates | relative
  seed=INT         fixes the samples and the methods' randomness (default 0)
  limit=INT        only the first INT samples (INT >= 1)
  lock_timeout=S   a second run into a busy run directory waits for the first; give up after S seconds
  method.KEY=VAL   any method option, e.g. method.optimiser.lr=0.001; dataset.root=PATH for real data
  output_root=DIR  where run directories go (default: outputs)
  -m               sweep comma-separated values: bench run -m method=icp,ours seed=0,1
  +experiment=NAME one paper table's sweep (configs/experiment/NAME.yaml), with -m
  hydra/launcher=L with -m: local_procs | slurm | ray_local (presets) or joblib | submitit_slurm |
                   submitit_local | ray (the cluster extra, `make cluster`); README "Scale out"
  shard=I shards=N only the I-th of N deterministic parts of the samples (sweep shard=range(N))

Writes <output_root>/<dataset>-<protocol>/<method>/seed<S>-<overrides>-<hash>/ with samples.jsonl,
samples.csv, summary.csv, summary.md, config.yaml and git_rev.txt. Re-running the same command
skips finished samples. A sweep writes <output_root>/multirun/<name>/<time>/<job>/job.json per job
and exits non-zero when a job failed. Show the composed config with: bench run --cfg job"""


def evaluate_main(argv: list[str]) -> int:
    """Recompute errors and summaries of run directories from their files."""
    parser = argparse.ArgumentParser(prog="bench evaluate", description=evaluate_main.__doc__)
    parser.add_argument("run_dirs", nargs="+", type=Path, help="run directories (with samples.jsonl)")
    args = parser.parse_args(argv)
    from catpose.bench.run.evaluate import format_summary, summarize_run
    from catpose.bench.run.rundir import SAMPLES_FILE

    for d in args.run_dirs:
        if not (d / SAMPLES_FILE).exists():
            raise ConfigError(f"{d} is not a run directory (no {SAMPLES_FILE}); pass a folder written by bench run")
        print(f"{d}:\n{format_summary(summarize_run(d))}\n")
    return 0
