"""Sweeps (``bench run -m``): one directory per sweep, one status file per job, an exit code.

Whatever Hydra's launcher (basic, joblib, submitit, Ray), every job writes
``<sweep dir>/<job num>/job.json`` from its own process (:class:`SweepStatus`'s ``on_job_end``:
``{"job", "overrides", "status": "ok"|"failed", "error", "run_dir", "label"}``) and the parent reads
them when the sweep ends, so a failed job reaches the exit code through the file system. The sweep
directory is ``<output_root>/multirun/<hydra.job.name>/<time>`` (``configs/run.yaml``); ``bench
table --sweep DIR`` reads it (:func:`read_sweep`)."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback

from catpose import atomic

log = logging.getLogger(__name__)

JOB_FILE = "job.json"

#: the failed jobs of the last sweep that ended in this process (set by ``on_multirun_end``)
last_sweep: dict[str, Any] = {}


def job_record(num: int, overrides: list[str], result: Any, error: BaseException | None) -> dict:
    """The ``job.json`` of one job from the task function's return value or its exception."""
    if error is not None:
        result = {"status": "failed", "error": " ".join(f"{type(error).__name__}: {error}".split())}
    result = result if isinstance(result, dict) else {}
    record = {"job": num, "overrides": overrides, "status": result.get("status", "failed")}
    return record | {k: result.get(k) for k in ("error", "run_dir", "label")}


def read_sweep(sweep_dir: str | Path) -> list[dict]:
    """The ``job.json`` records of a sweep directory, by job number."""
    sweep_dir = Path(sweep_dir)
    records = []
    for p in sweep_dir.glob(f"*/{JOB_FILE}"):
        try:
            records.append(json.loads(p.read_text()))
        except (OSError, json.JSONDecodeError):
            records.append({"job": p.parent.name, "status": "failed", "error": f"unreadable {p}", "run_dir": None})
    return sorted(records, key=lambda r: int(r["job"]) if str(r.get("job", "")).isdigit() else 1 << 30)


class SweepStatus(Callback):
    """Hydra callback (``hydra.callbacks.sweep_status`` in ``configs/run.yaml``)."""

    def on_job_end(self, config: Any, job_return: Any, **kwargs: Any) -> None:
        from hydra.core.hydra_config import HydraConfig
        from hydra.core.utils import JobStatus
        from hydra.types import RunMode

        hc = HydraConfig.get()
        if hc.mode != RunMode.MULTIRUN:
            return
        failed = job_return.status == JobStatus.FAILED
        record = job_record(
            int(hc.job.num),
            list(hc.overrides.task),
            None if failed else job_return._return_value,
            job_return._return_value if failed else None,
        )
        out = Path(hc.runtime.output_dir)
        out.mkdir(parents=True, exist_ok=True)
        atomic.write_text(out / JOB_FILE, json.dumps(record, indent=1) + "\n")  # the parent never reads half a file

    def on_multirun_end(self, config: Any, **kwargs: Any) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        records = read_sweep(sweep_dir)
        failed = [r for r in records if r.get("status") != "ok"]
        last_sweep.clear()
        last_sweep.update(sweep_dir=str(sweep_dir), jobs=len(records), failed=failed)
        text = (
            f"sweep {sweep_dir}: {len(records) - len(failed)} of {len(records)} jobs ok"
            + (f", {len(failed)} failed" if failed else "")
            + f"; table: bench table --sweep {sweep_dir}"
        )
        text += "".join(
            f"\n  job {r.get('job')} {' '.join(r.get('overrides') or [])}: {r.get('error')}" for r in failed
        )
        (log.error if failed else log.info)(text)
