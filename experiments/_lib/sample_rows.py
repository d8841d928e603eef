"""The per-sample loop of ours' studies (``rest_recall``, ``depth_check_masks``, ``outside_mask``):
ours and the problems built and seeded as ``bench run`` builds and seeds them, so their answers are
the run's; one JSON line per sample, finished samples skipped on a rerun; and the tables' reading of
those lines."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np


def build(seed: int, overrides: list[str]) -> tuple[Any, Any, Any, Any]:
    """(cfg, method, dataset, protocol) of ``bench run method=ours seed=SEED threads=1 OVERRIDES``,
    with the kernels' threads set as the run sets them."""
    from catpose import kernel_threads
    from catpose.bench.run.config import compose_and_build

    cfg, [(_, method), (_, dataset), (_, protocol)] = compose_and_build(
        ["method=ours", f"seed={seed}", "threads=1", *overrides], ["method", "dataset", "protocol"]
    )
    kernel_threads.set_threads(cfg.get("threads"))
    return cfg, method, dataset, protocol


def read_rows(path: Path) -> list[dict]:
    """The JSON lines of ``path`` (none when it does not exist)."""
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def done_ids(path: Path) -> set[str]:
    """The samples ``path`` already holds."""
    return {r["sample_id"] for r in read_rows(path)}


def register_seeded(method: Any, problem: Any, seed: int, sample_id: str) -> tuple[Any, float]:
    """``method.register(problem)`` seeded per sample as ``bench run`` seeds it, and its seconds."""
    from catpose.geometry import seed_everything, stable_seed

    seed_everything(stable_seed(seed, sample_id))
    t0 = time.perf_counter()
    result = method.register(problem)
    return result, time.perf_counter() - t0


def answer_errors(result: Any, gt: Any) -> tuple[np.ndarray, float, dict, float]:
    """(the answer's pose, its error, the error of each stage's best held pose, found@10's error:
    the least of them), in degrees."""
    from catpose.bench.scoring.metrics import sample_errors, stage_errors

    T = np.asarray(result.T_template_camera, float)
    err = float(sample_errors(T, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)["err_deg"])
    stages = stage_errors(
        result.extras.get("hypothesis_stages", {}), gt.T_template_camera, gt.symmetry_axis, gt.symmetries
    )
    return T, err, stages, float(np.nanmin([err, *stages.values()]))


def spread(values: list[float]) -> str:
    """``mean`` or ``mean [min-max]`` of per-seed figures; ``n/a`` without any."""
    if not values:
        return "n/a"
    a = np.asarray(values)
    if a.max() - a.min() < 5e-4:
        return f"{a.mean():.3f}"
    return f"{a.mean():.3f} [{a.min():.3f}-{a.max():.3f}]"
