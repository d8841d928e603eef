"""The per-sample row: the schema of one line of a run's ``samples.jsonl`` and the constructors
every row in catpose is made with (:class:`SampleRow`, :func:`new_row`, :func:`failed_row`,
:func:`scored_row`). The runner, the relative protocol and external predictions all write rows
made here, so every table reads one schema; it lives with the scoring because a row is what a
sample's scoring produces, and the protocols can take it without depending on the runner.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from catpose.bench.scoring.metrics import FAILED_ERROR_DEG


@dataclass
class SampleRow:
    """One line of ``samples.jsonl``: which problem, what the method answered, and its errors.

    Frames and units: ``T_est`` and ``T_gt`` are ``T_template_camera`` (16 floats, row-major),
    translations in the dataset's unit (object-normalised for the built-in sets); errors in
    degrees (``rot_err_deg``, ``axis_err_deg``, ``err_deg`` the one the statistics use) and in that
    unit (``trans_err``); ``runtime_s`` in seconds. ``status`` is ``ok`` or ``failed`` (then
    ``error`` says why, ``stage`` where, and ``err_deg`` is 180). ``found_err_deg`` is the error of
    the best hypothesis the method held at any stage of its search, the chosen one included
    (None: the method names no stages); ``info["hypothesis_errors"]`` has it per stage.
    ``info["runner_up_err_deg"]`` is the error of the method's runner-up (``extras["runner_up"]``:
    its next-best other answer), when it names one.
    """

    method: str
    dataset: str
    protocol: str
    seed: int
    sample_id: str
    group_id: str = ""
    obs_id: str = ""
    category: str | None = None
    instance_id: str | None = None
    template_id: str | None = None
    status: str = "failed"
    error: str = ""
    stage: str = "load"
    rot_err_deg: float | None = None
    axis_err_deg: float | None = None
    trans_err: float | None = None
    err_deg: float = FAILED_ERROR_DEG
    found_err_deg: float | None = None
    symmetric: bool | None = None
    score: float | None = None
    runtime_s: float | None = None
    T_est: Any = None
    T_gt: Any = None
    symmetry_axis: Any = None
    symmetries: Any = None
    info: dict = field(default_factory=dict)
    extras: dict = field(default_factory=dict)


def row_array(value: Any, shape: tuple[int, ...] = (4, 4)) -> np.ndarray | None:
    """A row's pose (``T_est``, ``T_gt``: 16 floats) or, with ``shape=(3,)``, axis as an array;
    None when the row has none (None, or NaN where a table filled a missing value)."""
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return None
    return np.asarray(value, float).reshape(shape)


def new_row(base: dict, sample_id: str, **fields: Any) -> dict:
    """A fresh row (status failed at stage load until told otherwise) for ``sample_id``;
    ``base`` holds method, dataset, protocol and seed."""
    row = dataclasses.asdict(
        SampleRow(
            method=str(base["method"]),
            dataset=str(base["dataset"]),
            protocol=str(base["protocol"]),
            seed=int(base["seed"]),
            sample_id=sample_id,
            group_id=sample_id,
            obs_id=sample_id.split("|")[0],
        )
    )
    row.update(fields)
    return row


def failed_row(row: dict, error: str, stage: str | None = None, **fields: Any) -> dict:
    """``row`` marked failed with ``error`` (one line): no estimate, counted as 180 degrees."""
    out = dict(row, status="failed", error=error, T_est=None, err_deg=FAILED_ERROR_DEG)
    out.update(rot_err_deg=None, axis_err_deg=None, trans_err=None)
    if stage is not None:
        out["stage"] = stage
    out.update(fields)
    return out


def scored_row(row: dict, T_est: np.ndarray, errors: dict, **fields: Any) -> dict:
    """``row`` with the estimate ``T_est`` (4, 4) and its ``errors`` (see
    :func:`catpose.bench.scoring.metrics.sample_errors`)."""
    out = dict(row, status="ok", error="", stage="", T_est=np.asarray(T_est, float).reshape(-1).tolist())
    out.update(errors)
    out.update(fields)
    return out
