"""``bench run``: Hydra's ``hydra.main``, after the checks of :mod:`catpose.bench.run.config`."""

from __future__ import annotations

import sys
from pathlib import Path

from catpose.bench.run import config
from catpose.bench.run.config import OTHER_CONFIGS, flag_names, split_hydra_args
from catpose.errors import CatposeError, command_error


def main(argv: list[str]) -> int:
    if any(a in ("-h", "--help") for a in argv):
        print(__doc_run__)
        return 0
    flags, overrides = split_hydra_args(argv)
    config.check_run_args(argv)  # plain overrides only: Hydra's flags (--cfg, --info, ...) and hydra.* pass untouched
    return _hydra_main(argv + output_overrides(flags, overrides))


#: Hydra job logging configs that write no file (the run directory need not be Hydra's folder)
CONSOLE_ONLY_LOGGING = ("none", "disabled", "stdout")


def output_overrides(flags: list[str], overrides: list[str]) -> list[str]:
    """Hydra overrides that put Hydra's own files where a Hydra user expects them.

    - ``hydra/job_logging=NAME`` writing a log file, without ``hydra.run.dir``: Hydra's folder
      becomes the run directory named from the parameters, so the log (``run.log``) and
      ``.hydra/`` land in it rather than in the working directory.
    - a sweep (``-m``): each job's folder ``<hydra.sweep.dir>/<num>/`` gets ``.hydra/`` beside
      its ``job.json``; the runs stay under ``output_root``, named from their parameters.

    ``hydra.run.dir=DIR`` places only Hydra's own outputs, as in Hydra; a run's files always go
    to its run directory under ``output_root``.
    """
    names = flag_names(flags)
    if names & {"--cfg", "--info", "--shell-completion", "--hydra-help", "--version"}:
        return []
    keys = {o.partition("=")[0].lstrip("+~"): o.partition("=")[2] for o in overrides}
    subdir = [] if "hydra.output_subdir" in keys else ["hydra.output_subdir=.hydra"]
    if "--multirun" in names:
        return subdir
    name = [] if "hydra.job.name" in keys else ["hydra.job.name=run"]
    if "hydra.run.dir" in keys:  # Hydra's .hydra/ and log there; the run's files stay under output_root
        return subdir + name
    logging_config = keys.get("hydra/job_logging")
    plain = [o for o in overrides if not o.lstrip("+~").startswith("hydra")]
    if (
        logging_config is None
        or logging_config.strip("'\"") in CONSOLE_ONLY_LOGGING
        or names & set(OTHER_CONFIGS)
        or any(o.lstrip("+~").startswith("experiment") for o in plain)
    ):  # an experiment is composed by Hydra alone: its logging stays in Hydra's folder
        return []
    from catpose.bench.run.rundir import run_dir_for

    out = run_dir_for(config.compose(plain), plain)
    return subdir + name + [f"hydra.run.dir='{out}'"]  # quoted: a run's tag holds = , [ ]


def _hydra_main(argv: list[str]) -> int:
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
            out = run(cfg, task)
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
  bench run -m method=icp,ours dataset=synthetic seed=0,1 limit=2
  bench run method=ours --cfg job"""
