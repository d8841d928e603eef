"""A run directory's metadata read back: ``config.yaml`` and ``run.json``, or one line naming the
run and the file when either is unreadable (a 0-byte file left by a full disk, a hand edit), never
a YAML or JSON traceback. Tables, reports, exports and summaries read them through here."""

from __future__ import annotations

import json
from pathlib import Path

from catpose.errors import DatasetError

_FIX = "re-run the same `bench run` command to rewrite it (finished samples are skipped), or restore it from a copy"


def read_config(run_dir: Path, required: bool = False) -> dict:
    """``config.yaml`` of ``run_dir`` as a plain dict (interpolations left as written); {} when the
    file is absent and not ``required``. Raises :class:`DatasetError` naming the run otherwise."""
    from omegaconf import OmegaConf

    path = Path(run_dir) / "config.yaml"
    if not path.is_file():
        if required:
            raise DatasetError(f"run {run_dir}: config.yaml is missing; {_FIX}")
        return {}
    try:
        cfg = OmegaConf.to_container(OmegaConf.load(path), resolve=False)
    except Exception as e:  # noqa: BLE001 - yaml, OmegaConf and OS errors alike: one line naming the run
        why = " ".join(str(e).split())[:120] or type(e).__name__
        raise DatasetError(f"run {run_dir}: config.yaml is unreadable ({why}); {_FIX}") from None
    if not isinstance(cfg, dict) or not cfg:
        raise DatasetError(f"run {run_dir}: config.yaml is empty or not a mapping; {_FIX}")
    return cfg


def read_run_json(run_dir: Path) -> dict:
    """``run.json`` of ``run_dir`` as a dict ({} when absent); :class:`DatasetError` naming the run
    when it is there but unreadable."""
    path = Path(run_dir) / "run.json"
    if not path.is_file():
        return {}
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        why = "an empty file" if path.stat().st_size == 0 else f"{type(e).__name__}: {' '.join(str(e).split())[:80]}"
        raise DatasetError(f"run {run_dir}: run.json is unreadable ({why}); {_FIX}") from None
    if not isinstance(info, dict):
        raise DatasetError(f"run {run_dir}: run.json is not a JSON object; {_FIX}")
    return info


def incomplete_reason(run_dir: Path, info: dict, n_rows: int) -> str | None:
    """Why the run directory ``run_dir`` does not hold a finished run, in one line (None when it does).

    ``bench run`` records ``state: running`` in ``run.json`` before its first sample and
    ``state: finished`` after its last; a run killed (``kill -9``), or still running, is left
    ``running``. ``info``: its ``run.json`` (:func:`read_run_json`); ``n_rows``: its samples."""
    fix = "re-run the same `bench run` command to finish it (finished samples are skipped)"
    if info.get("state") == "running":
        planned = info.get("n_samples")
        of = f" of the {planned} its last `bench run` was to do" if isinstance(planned, int) else ""
        return f"run {run_dir} is incomplete: it holds {n_rows} samples{of}, and that run was stopped or is still running; {fix}"
    if info.get("state") not in (None, "running", "finished"):
        return f"run {run_dir}: run.json has state {info['state']!r}, which no `bench run` writes; {fix}"
    planned = info.get("n_samples")
    if info.get("state") == "finished" and isinstance(planned, int) and planned > n_rows:
        return (
            f"run {run_dir} is incomplete: it holds {n_rows} samples of the {planned} its finished run recorded "
            f"(rows lost from samples.jsonl); {fix}"
        )
    return None
