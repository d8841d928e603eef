"""``bench run`` (Hydra's ``hydra.main``, after the checks of :mod:`catpose.bench.run.config`) and
``bench evaluate``."""

from __future__ import annotations

import sys
from pathlib import Path

from catpose.bench.run import config
from catpose.errors import CatposeError, command_error


def main(argv: list[str]) -> int:
    if any(a in ("-h", "--help") for a in argv):
        print(__doc_run__)
        return 0
    config.check_run_args(argv)  # plain overrides only: Hydra's flags (--cfg, --info, ...) and hydra.* pass untouched
    import hydra
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    @hydra.main(version_base="1.3", config_path="pkg://catpose.configs", config_name="run")
    def _job(cfg) -> dict:
        from catpose import logs
        from catpose.bench.run.runner import run
        from catpose.errors import RunAborted

        hc = HydraConfig.get()
        try:
            logs.configure_run(
                cfg.get("log_level", "INFO"),
                hc.verbose,
                hydra_logging=bool(hc.job_logging) and hc.job_logging.get("root") is not None,
            )
            out = run(cfg, list(hc.overrides.task))
        except RunAborted as e:  # not this job's fault (disk full, broken install): stop the sweep too
            print(command_error("run", e), file=sys.stderr)
            raise SystemExit(2) from None
        except CatposeError as e:
            # one line, not Hydra's report; a sweep goes on with its other jobs, and the job's
            # status reaches the parent through <sweep dir>/<job>/job.json (bench/run/sweep.py)
            if hc.mode == RunMode.MULTIRUN:
                print(command_error("run", f"in job {list(hc.overrides.task)}: {e}"), file=sys.stderr)
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
  method.KEY=VAL   any method option, e.g. method.optimiser.lr=0.001; dataset.root=PATH for real data
  output_root=DIR  where run directories go (default: outputs)
  -m               sweep comma-separated values: bench run -m method=icp,ours seed=0,1
  +experiment=NAME one paper table's sweep (configs/experiment/NAME.yaml), with -m
  hydra/launcher=L with -m: local_procs | slurm | ray_local (presets) or joblib | submitit_slurm |
                   submitit_local | ray (the cluster extra, `make cluster`); docs/scale-out.md
  shard=I shards=N only the I-th of N deterministic parts of the samples (sweep shard=range(N))
  log_level=LEVEL  DEBUG | INFO (default) | WARNING | ERROR: catpose's messages on stderr
                   (hydra.verbose=true or hydra.verbose=catpose: DEBUG)

Hydra's own flags pass through: --cfg job|hydra|all [--resolve] [--package PKG] prints the
composed config instead of running; --info [plugins|config|defaults|defaults-tree|searchpath];
--config-dir DIR adds a config folder; --hydra-help; hydra.KEY=VALUE overrides.

Writes <output_root>/<dataset>-<protocol>/<method>/seed<S>-<overrides>-<hash>/ with samples.jsonl,
samples.csv, summary.csv, summary.md, config.yaml and git_rev.txt. Re-running the same command
skips finished samples. A sweep writes <output_root>/multirun/<name>/<time>/<job>/job.json per job
and exits non-zero when a job failed."""


def evaluate_main(argv: list[str]) -> int:
    """Recompute errors and summaries of run directories from their files (:mod:`catpose.bench.run.evaluate`)."""
    from catpose.bench.run.evaluate import main

    return main(argv)
