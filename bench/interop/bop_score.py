"""BOP's metrics of a BOP results CSV, the second stage of ``bench score`` on a BOP dataset:
the errors of every target (:mod:`catpose.bench.scoring.bop_eval`) against the dataset's
evaluation models, written beside the scored run as ``bop_errors.jsonl`` and ``bop_summary.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from catpose import atomic
from catpose.bench.scoring.bop_rows import evaluation_models
from catpose.errors import InvalidInputError

DEFAULT_BOP_METRICS = ("ar", "ar_mssd", "ar_mspd", "ar_vsd", "adds@0.1", "5deg5cm", "10deg10cm")


def score_bop(
    preds,
    dataset_cfg: dict,
    out_dir: str | Path,
    method: str,
    metrics: Sequence[str],
    by: Sequence[str],
    vsd: bool = True,
) -> str:
    """BOP metrics of a BOP results CSV on the dataset of ``dataset_cfg`` (a resolved config
    dict): writes ``bop_errors.jsonl`` and ``bop_summary.md`` into ``out_dir`` and returns the
    summary (which states the target and visibility filters applied, and the models used: the
    dataset's ``models_eval/`` when present, :func:`evaluation_models`)."""
    from catpose.bench.run.build import build_from_config
    from catpose.bench.scoring.bop_eval import ERRORS_FILE, compute_errors, format_scores, score_table, write_errors

    dataset_cfg = evaluation_models(dataset_cfg)
    _, ds = build_from_config(dict(dataset_cfg), "dataset")
    errs = compute_errors(preds, ds, vsd=vsd)
    instances: dict[tuple, int] = {}
    for r in errs:
        key = (int(r["scene_id"]), int(r["im_id"]), int(r["obj_id"]))
        instances[key] = instances.get(key, 0) + 1
    estimates: dict[tuple, int] = {}
    for p in preds.to_dict("records"):
        key = (int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"]))
        estimates[key] = estimates.get(key, 0) + 1
    filters = list(getattr(ds, "filters", [])) + [f"models: {dataset_cfg.get('models_dir', 'models')}/"]
    header = {
        "method": method,
        "filters": filters,
        "targets": len(errs),
        "matched": int(sum(r["matched"] for r in errs)),
        # ignored, and said so: estimates of no target, and those beyond an (image, object)'s instances
        "unknown_estimates": sum(n for k, n in estimates.items() if k not in instances),
        "extra_estimates": sum(max(0, n - instances[k]) for k, n in estimates.items() if k in instances),
    }
    write_errors(errs, Path(out_dir) / ERRORS_FILE, header)
    import pandas as pd

    text = f"BOP metrics ({method}):\n" + format_scores(score_table(pd.DataFrame(errs), metrics, by), header)
    atomic.write_text(Path(out_dir) / "bop_summary.md", text + "\n")
    return text


def bop_metrics(asked: str | None, no_vsd: bool) -> str:
    """The BOP recalls to print: ``--metrics`` or :data:`DEFAULT_BOP_METRICS`; with ``--no-vsd``
    the defaults lose ``ar`` and ``ar_vsd`` (BOP's AR needs VSD), and asking for them is refused."""
    if asked is None:
        return ",".join(m for m in DEFAULT_BOP_METRICS if not (no_vsd and m in ("ar", "ar_vsd")))
    needs_vsd = [m for m in asked.split(",") if m.strip().lower() in ("ar", "ar_vsd")]
    if no_vsd and needs_vsd:
        raise InvalidInputError(
            f"--metrics {','.join(needs_vsd)} needs VSD, which --no-vsd skips (BOP's AR is the mean of ar_mssd, "
            "ar_mspd and ar_vsd); drop --no-vsd, or ask for ar_mssd,ar_mspd"
        )
    return asked
