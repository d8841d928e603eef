"""The run directories, labels and table settings of sweeps (``bench run -m``), for ``bench table --sweep``."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from catpose.errors import ConfigError, DatasetError


def sweep_runs(sweep_dirs: Sequence[str | Path]) -> tuple[list[Path], dict[str, str], dict[str, Any]]:
    """Run directories, labels and table settings of sweeps (``bench run -m``).

    Reads each job's ``job.json`` (:mod:`catpose.bench.run.sweep`) and the sweep's ``multirun.yaml``,
    whose ``table`` node (set by ``configs/experiment/*.yaml``) gives ``layout``, ``categories``,
    ``metrics``, ``error`` and ``title``. A failed or unfinished job stops the table with a
    one-line error naming it."""
    from catpose.bench.run.sweep import read_sweep

    paths: list[Path] = []
    labels: dict[str, str] = {}
    settings: dict[str, Any] = {}
    for d in map(Path, sweep_dirs):
        records = read_sweep(d)
        if not records:
            raise DatasetError(
                f"{d} is not a sweep directory (no */job.json); pass <output_root>/multirun/<name>/<time> "
                f"of a `bench run -m` that has finished"
            )
        bad = [r for r in records if r.get("status") != "ok" or not r.get("run_dir")]
        if bad:
            raise DatasetError(
                f"sweep {d}: job {bad[0].get('job')} ({' '.join(bad[0].get('overrides') or [])}) failed: "
                f"{bad[0].get('error')}; re-run the sweep (finished samples are skipped)"
            )
        for r in records:
            run_dir = Path(r["run_dir"])
            if run_dir not in paths:
                paths.append(run_dir)
            if r.get("label"):
                labels.update({str(run_dir): r["label"], str(run_dir.resolve()): r["label"]})
        if (d / "multirun.yaml").is_file() and not settings:
            from omegaconf import OmegaConf

            table = OmegaConf.to_container(OmegaConf.load(d / "multirun.yaml"), resolve=False).get("table") or {}
            settings = {k: v for k, v in table.items() if k in ("layout", "categories", "metrics", "error", "title")}
    from catpose.bench.report.tables import LAYOUTS

    if settings.get("layout") not in (None, *LAYOUTS):
        raise ConfigError(f"the sweep's table.layout {settings['layout']!r} is not one of {sorted(LAYOUTS)}")
    return paths, labels, settings
