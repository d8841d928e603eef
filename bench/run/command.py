"""``bench run``: Hydra's ``hydra.main``, after the checks of :mod:`catpose.bench.run.config`."""

from __future__ import annotations

import sys
from pathlib import Path

from catpose.bench.run import config
from catpose.bench.run.hydra_flags import OTHER_CONFIGS, flag_names, split_hydra_args
from catpose.errors import CatposeError, ConfigError, command_error


def main(argv: list[str]) -> int:
    if any(a in ("-h", "--help") for a in argv):
        print(__doc_run__)
        return 0
    flags, overrides = split_hydra_args(argv)
    config.check_run_args(argv)  # plain overrides only: Hydra's flags (--cfg, --info, ...) and hydra.* pass untouched
    extra, named = output_overrides(flags, overrides)
    return _hydra_main(argv + extra, named_run_dir=named)


#: Hydra job logging configs that write no file (the run directory need not be Hydra's folder)
CONSOLE_ONLY_LOGGING = ("none", "disabled", "stdout")


def output_overrides(flags: list[str], overrides: list[str]) -> tuple[list[str], bool]:
    """Hydra overrides that put Hydra's own files where a Hydra user expects them, and whether a
    single run goes into Hydra's output folder (``hydra.run.dir``) instead of the folder named
    from its parameters.

    - ``hydra.run.dir=DIR`` (a single run): the run's files go into ``DIR``, with Hydra's
      ``.hydra/`` (the composed config, Hydra's config, the overrides) beside them.
    - ``hydra/job_logging=NAME`` writing a log file, without ``hydra.run.dir``: Hydra's folder
      becomes the run directory named from the parameters, so the log (``run.log``) and
      ``.hydra/`` land in it rather than in the working directory.
    - a sweep (``-m``): each job's folder ``<hydra.sweep.dir>/<num>/`` gets ``.hydra/`` beside
      its ``job.json``; the runs stay under ``output_root``, named from their parameters.
    """
    names = flag_names(flags)
    if names & {"--cfg", "--info", "--shell-completion", "--hydra-help", "--version"}:
        return [], False
    keys = {o.partition("=")[0].lstrip("+~"): o.partition("=")[2].strip("'\"") for o in overrides}
    subdir = [] if "hydra.output_subdir" in keys else ["hydra.output_subdir=.hydra"]
    if "--multirun" in names:
        return subdir, False
    plain = [o for o in overrides if not o.lstrip("+~").startswith("hydra")]
    if "hydra.run.dir" in keys:
        cfg = _composed(plain) if "${" not in keys["hydra.run.dir"] and not names & set(OTHER_CONFIGS) else None
        if cfg is not None:  # before Hydra writes its .hydra/ there (the job checks the folder again)
            check_named_run_dir(Path(keys["hydra.run.dir"]), cfg, "run.log")
        return subdir + ([] if "hydra.job.name" in keys else ["hydra.job.name=run"]), True
    logging_config = keys.get("hydra/job_logging")
    if logging_config is None or logging_config in CONSOLE_ONLY_LOGGING or names & set(OTHER_CONFIGS):
        return [], False
    from catpose.bench.run.rundir import run_dir_for

    cfg = _composed(plain)
    if cfg is None:  # composed by Hydra alone (an experiment): its logging stays Hydra's folder
        return [], False
    out = run_dir_for(cfg, plain)
    name = [] if "hydra.job.name" in keys else ["hydra.job.name=run"]
    return subdir + name + [f"hydra.run.dir='{out}'"], True  # quoted: a run's tag holds = , [ ]


def _composed(overrides: list[str]):
    """The run config of a single run's plain overrides, or None where only Hydra composes it
    (``+experiment=...``)."""
    if any(o.lstrip("+~").startswith("experiment") for o in overrides):
        return None
    return config.compose(overrides)


def check_named_run_dir(out: Path, cfg, log_name: str) -> None:
    """Refuse, in one line, a ``hydra.run.dir`` that holds anything but this configuration's
    run (Hydra's ``.hydra/`` and the job's log aside): another configuration's run, or files of
    no run. No command writes into what it did not create."""
    import os

    from omegaconf import OmegaConf

    from catpose.bench.run.overwrite import run_above
    from catpose.bench.run.rundir import run_dir_for

    outer = run_above(Path(os.path.realpath(out)))
    if outer is not None:
        raise ConfigError(f"hydra.run.dir={out} lies inside the run directory {outer}; name a folder outside it")
    existing = next(p for p in (out, *out.absolute().parents) if p.exists())
    if existing.is_file():
        raise ConfigError(f"hydra.run.dir={out}: {existing} is a file, not a folder; name a new or empty folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"hydra.run.dir={out}: the folder {existing} is not writable; name a writable folder")
    if not out.is_dir():
        return
    entries = sorted(p.name for p in out.iterdir() if p.name not in (".hydra", log_name))
    if not entries:
        return
    if "config.yaml" in entries:
        try:
            old = OmegaConf.load(out / "config.yaml")
            same = run_dir_for(old).name.rsplit("-", 1)[-1] == run_dir_for(cfg).name.rsplit("-", 1)[-1]
            what = f"{old.method.name} on {old.dataset.name} ({old.protocol.name}), seed {old.seed}"
        except Exception:  # noqa: BLE001 - a config.yaml that is not a run's: refused below
            same, what = False, "an unreadable config.yaml"
        if same:
            return
        raise ConfigError(
            f"hydra.run.dir={out} holds a run of another configuration ({what}); "
            "name a new folder, or leave hydra.run.dir out (runs are then named from their parameters under output_root)"
        )
    shown = ", ".join(entries[:3]) + (", ..." if len(entries) > 3 else "")
    raise ConfigError(
        f"hydra.run.dir={out} holds {len(entries)} file(s) of no run ({shown}); name an empty or new folder"
    )


def _hydra_main(argv: list[str], named_run_dir: bool) -> int:
    """``bench run``'s ``hydra.main`` over ``argv`` (the checks done); the exit status."""
    import hydra
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    @hydra.main(version_base="1.3", config_path="pkg://catpose.configs", config_name="run")
    def _job(cfg) -> dict:
        import logging

        from omegaconf import open_dict

        from catpose import logs
        from catpose.bench.run.runner import run
        from catpose.errors import RunAborted

        hc = HydraConfig.get()
        task = list(hc.overrides.task)
        try:
            level = logs.configure_run(
                cfg.get("log_level", "INFO"),
                hc.verbose,
                hydra_logging=bool(hc.job_logging) and hc.job_logging.get("root") is not None,
            )
            if level > logging.INFO and not any(o.partition("=")[0] == "progress" for o in task):
                with open_dict(cfg):  # a quiet run shows no progress bar either, unless asked for
                    cfg.progress = False
            run_dir = None
            if named_run_dir and hc.mode == RunMode.RUN:
                run_dir = Path(str(hc.run.dir))
                check_named_run_dir(run_dir, cfg, f"{hc.job.name}.log")
            out = run(cfg, task, run_dir=run_dir)
        except RunAborted as e:  # not this job's fault (disk full, broken install): stop the sweep too
            print(command_error("run", e), file=sys.stderr)
            raise SystemExit(2) from None
        except CatposeError as e:
            # one line, not Hydra's report; a sweep goes on with its other jobs, and the job's
            # status reaches the parent through <sweep dir>/<job>/job.json (bench/run/sweep.py)
            if hc.mode == RunMode.MULTIRUN:
                print(command_error("run", f"in job {task}: {e}"), file=sys.stderr)
                return {"status": "failed", "error": str(e)}
            print(command_error("run", e), file=sys.stderr)
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
  choice=RULE      templates, relative: which of a view's K registrations is kept, one of
                   configs/choice/*.yaml (score, cross, fused, ...); choice.KEY=VAL its weights
  seed=INT         fixes the samples and the methods' randomness (default 0)
  limit=INT        only the first INT samples (INT >= 1)
  lock_timeout=S   a second run into a busy run directory waits for the first; give up after S seconds
  method.KEY=VAL   an option of the chosen method (method=ours method.optimiser.irls_iterations=10);
                   dataset.root=PATH for real data; a misspelt key or name gets the closest ones
  output_root=DIR  where run directories go (default: outputs)
  hydra.run.dir=DIR  this run's files (and Hydra's .hydra/) in DIR instead of the named folder
  -m               sweep comma-separated values: bench run -m method=icp,ours seed=0,1
  +experiment=NAME one paper table's sweep (configs/experiment/NAME.yaml), with -m
  hydra/launcher=L with -m: local_procs | slurm | ray_local (presets) or joblib | submitit_slurm |
                   submitit_local | ray (the cluster extra, `make cluster`); docs/scale-out.md
  log_level=LEVEL  DEBUG | INFO (default) | WARNING | ERROR: catpose's messages on stderr; above
                   INFO also no progress bar (progress=true keeps it); hydra.verbose=true: DEBUG
  hydra/job_logging=default  Hydra's logging (console and run.log in the run directory)

Hydra's own flags pass through: --cfg job|hydra|all [--resolve] [--package PKG] prints the
composed config instead of running; --info [plugins|config|defaults|defaults-tree|searchpath];
--config-dir DIR adds a config folder; --hydra-help; hydra.KEY=VALUE overrides.

Writes <output_root>/<dataset>-<protocol>/<method>/seed<S>-<overrides>-<hash>/ with samples.jsonl,
samples.csv, summary.csv, summary.md, config.yaml and git_rev.txt. Re-running the same command
skips finished samples. A sweep writes <output_root>/multirun/<name>/<time>/<job>/job.json (and
Hydra's .hydra/) per job, or under hydra.sweep.dir, and exits non-zero when a job failed.

examples:
  bench run method=ours dataset=synthetic limit=4
  bench run method=ours method.optimiser.irls_iterations=10 dataset=synthetic limit=2
  bench run method=icp dataset=synthetic limit=1 hydra.run.dir=outputs/first_icp
  bench run -m method=icp,ours dataset=synthetic seed=0,1 limit=2
  bench run method=ours --cfg job"""
