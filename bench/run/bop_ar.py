"""BOP's per-target errors of a run on BOP-layout data, for the AR columns of ``bench suite`` and
``bench table`` (:func:`target_errors`), computed with ``bench score``'s code and cached outside
the run, which a table command did not create and must not write into."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from catpose.bench.run.rundir import SAMPLES_FILE

#: bumped when the cached errors would change for the same run (a metric or matching fix)
VERSION = "1"


def _cache_dir() -> Path:
    from catpose.disk_cache import cache_dir

    return cache_dir() / "bop_errors"


def bop_dataset_config(run_dir: Path) -> dict | None:
    """The evaluation dataset config of a run on BOP-layout data (its ``models_eval`` when the
    dataset has them, as ``bench score``), or None for any other dataset."""
    from catpose.bench.run.run_meta import read_config
    from catpose.bench.scoring.bop_rows import evaluation_models, is_bop_layout

    cfg = read_config(Path(run_dir)).get("dataset")
    return evaluation_models(cfg) if is_bop_layout(cfg) else None


def target_errors(run_dir: str | Path):
    """Per-target BOP errors of a run (a DataFrame: ``compute_errors``' columns plus ``sample_id``),
    or None when the run is not on BOP-layout data or has no sample."""
    import pandas as pd

    from catpose.bench.run.evaluate import load_protocol, recompute_row_errors
    from catpose.bench.run.rundir import latest_rows

    run_dir = Path(run_dir)
    dataset_cfg = bop_dataset_config(run_dir)
    samples = run_dir / SAMPLES_FILE
    if dataset_cfg is None or not samples.is_file():
        return None
    h = hashlib.blake2b(digest_size=12)
    h.update(VERSION.encode())
    h.update(json.dumps(dataset_cfg, sort_keys=True, default=str).encode())
    h.update(samples.read_bytes())
    cached = _cache_dir() / f"{h.hexdigest()}.jsonl"
    if cached.is_file():
        try:
            return pd.DataFrame([json.loads(x) for x in cached.read_text().splitlines() if x.strip()])
        except (OSError, ValueError):
            pass  # a damaged entry is rebuilt
    rows = [recompute_row_errors(r) for r in latest_rows(samples)]
    if not rows:
        return None
    units = load_protocol(run_dir).score_units(pd.DataFrame(rows)).to_dict("records")
    errors = units_errors(units, dataset_cfg)
    from catpose import atomic

    try:
        atomic.write_text(cached, "".join(json.dumps(r) + "\n" for r in errors.to_dict("records")))
    except OSError:
        pass  # a read-only or full cache only costs the recomputation next time
    return errors


def units_errors(units: list[dict], dataset_cfg: dict):
    """Per-target errors of scoring units on the dataset of ``dataset_cfg`` (resolved, evaluation
    models chosen), restricted to the units' targets, each with its unit's ``sample_id``."""
    import pandas as pd

    from catpose.bench.run.build import build_from_config
    from catpose.bench.scoring.bop_eval import compute_errors
    from catpose.bench.scoring.bop_rows import predictions_from_units, target_key

    _, dataset = build_from_config(dict(dataset_cfg), "dataset")
    by_target = {target_key(u["info"]): u["sample_id"] for u in units if "gt_idx" in (u.get("info") or {})}
    errors = [r for r in compute_errors(predictions_from_units(units), dataset) if target_key(r) in by_target]
    for r in errors:
        r["sample_id"] = by_target[target_key(r)]
    return pd.DataFrame(errors)
