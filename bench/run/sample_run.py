"""One sample (or a batch of samples) through a method: load, register, check and score, into
its row of the run's table (:class:`catpose.bench.scoring.rows.SampleRow`).

What is the sample's own fault (its data fails to load, the method raises on it, the estimate is
not a finite rigid transform) becomes its row's ``error``; what is not (an import error, no
memory) is raised for the runner (:mod:`catpose.bench.run.runner`) to abort the run.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from catpose.bench.scoring.rows import failed_row, new_row, scored_row
from catpose.errors import one_line as _one_line
from catpose.geometry import seed_everything, stable_seed

# raised inside a sample but not its fault: the run aborts (see run()); KeyboardInterrupt and
# other BaseExceptions pass through `except Exception` anyway
_NOT_THE_SAMPLES_FAULT = (ImportError, MemoryError)


def _load_one(protocol: Any, dataset: Any, sample_id: str, base: dict) -> tuple[dict, Any]:
    """One sample's row and loaded sample; ``(failed row, None)`` when its data fails to load."""
    try:
        category = dataset.category_of(sample_id.split("|")[0])
    except Exception:  # an id the dataset cannot parse still gets its failed row below
        category = None
    row = new_row(base, sample_id, category=category)
    try:
        sample = protocol.load(dataset, sample_id)
    except _NOT_THE_SAMPLES_FAULT:
        raise
    except Exception as e:  # a bad sample is recorded, the run goes on
        return failed_row(row, _one_line(e)), None
    info = dict(sample.info)
    row.update(
        group_id=sample.group_id or sample_id,
        category=sample.problem.category,
        instance_id=info.get("instance_id"),
        template_id=sample.problem.template.template_id,
        T_gt=np.asarray(sample.gt.T_template_camera, float).reshape(-1),
        symmetric=sample.gt.symmetry_axis is not None,
        symmetry_axis=sample.gt.symmetry_axis,
        symmetries=[np.asarray(S, float).reshape(-1) for S in sample.gt.symmetries] or None,
        info=info,
        stage="register",
    )
    return row, sample


def _scored(row: dict, sample: Any, result: Any, runtime: float) -> dict:
    """The row of a registered sample: its estimate checked and scored."""
    from catpose.bench.scoring.metrics import sample_errors, stage_errors

    result = dataclasses.replace(result, runtime_s=runtime)
    T = np.asarray(result.T_template_camera, dtype=float)
    extras = dict(result.extras)
    stages = extras.pop("hypothesis_stages", None)  # poses, scored here and not stored
    row.update(runtime_s=runtime, score=result.score, extras=extras)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        return failed_row(row, f"method returned a non-finite or malformed pose (shape {T.shape})")
    R = T[:3, :3]
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
        return failed_row(row, "method returned a matrix whose rotation part is not a rotation")
    gt = sample.gt
    errors = sample_errors(T, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)
    if stages:  # hypothesis recall: the best pose the method held at each stage of its search
        found = stage_errors(stages, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)
        row["info"] = {**dict(row.get("info") or {}), "hypothesis_errors": found}
        errors["found_err_deg"] = float(np.nanmin([errors["err_deg"], *found.values()]))
    if result.runner_up is not None:  # the method's next-best other answer
        e2 = sample_errors(result.runner_up[0], gt.T_template_camera, gt.symmetry_axis, gt.symmetries)["err_deg"]
        row["info"] = {**dict(row.get("info") or {}), "runner_up_err_deg": float(e2)}
    return scored_row(row, T, errors)


def _register_one(method: Any, row: dict, sample: Any, seed: int) -> dict:
    """Register one loaded sample (seeded by its id) and score it; a failure that is the sample's
    own is its row's ``error``; what is not (an import error, no memory) is raised."""
    seed_everything(stable_seed(seed, row["sample_id"]))
    t0 = time.perf_counter()
    try:
        result = method.register(sample.problem)
    except _NOT_THE_SAMPLES_FAULT:
        raise
    except Exception as e:
        return failed_row(row, _one_line(e), runtime_s=time.perf_counter() - t0)
    return _scored(row, sample, result, time.perf_counter() - t0)


def facts_hook(protocol: Any, chooser: Any) -> Callable[[Any, Any, np.ndarray], dict] | None:
    """The facts hook of a run whose protocol keeps one of a view's K template registrations:
    ``hook(dataset, sample, T_template_camera)``, the choice's (``chooser``,
    :class:`catpose.methods.template_choice.TemplateChoice`) facts about one finished estimate
    (4, 4) on the templates ``protocol`` gives its view (the cross check's ICP, the top offset, the
    turned candidates); stored in the row's ``info``, where the protocol's scoring applies the rule.
    None unless the protocol lists a view's templates (``templates``, and ``relative`` with category
    templates) and the run has a choice (:func:`catpose.bench.run.build.build_choice`)."""
    if chooser is None or getattr(protocol, "view_templates", None) is None:
        return None

    def estimate_facts(dataset: Any, sample: Any, T_template_camera: np.ndarray) -> dict:
        templates, own = protocol.view_templates(dataset, sample)
        return chooser.estimate_facts(sample.problem.points_camera, templates, own, T_template_camera)

    return estimate_facts


def _with_estimate_facts(facts_hook: Any, dataset: Any, row: dict, sample: Any) -> dict:
    """``row`` with the facts about its finished estimate added to ``info`` (a templates run's
    choice facts, :func:`facts_hook`); a failed row, or no hook, is returned as it is. An error
    there is the sample's own: the estimate stays, and ``info["estimate_facts_error"]`` says why
    its facts are missing."""
    if row.get("status") != "ok" or facts_hook is None:
        return row
    try:
        facts = facts_hook(dataset, sample, np.asarray(row["T_est"], float).reshape(4, 4))
    except _NOT_THE_SAMPLES_FAULT:
        raise
    except Exception as e:  # noqa: BLE001 - recorded with the sample, the run goes on
        facts = {"estimate_facts_error": _one_line(e)}
    return dict(row, info={**dict(row.get("info") or {}), **facts}) if facts else row


def run_one(method: Any, protocol: Any, dataset: Any, sample_id: str, base: dict, seed: int, facts: Any = None) -> dict:
    """Load, register and score one sample; its row (see :class:`catpose.bench.scoring.rows.SampleRow`),
    with ``facts``' facts about the estimate (:func:`_with_estimate_facts`)."""
    return run_batch(method, protocol, dataset, [sample_id], base, seed, facts)[0]


def run_batch(
    method: Any, protocol: Any, dataset: Any, sample_ids: list[str], base: dict, seed: int, facts: Any = None
) -> list[dict]:
    """:func:`run_one` for several samples, registered with one ``method.register_batch`` call
    when the method has one (ours: one solver launch for the candidates of all of them, the GPU
    path); each sample's ``runtime_s`` is then its share of the call. A sample that fails to load
    is recorded and left out of the call; when the call raises for one problem, every sample of
    the batch registers alone, so that only the bad one is recorded as failed."""
    loaded = [_load_one(protocol, dataset, sid, base) for sid in sample_ids]
    ready = [(row, sample) for row, sample in loaded if sample is not None]
    scored: dict[str, dict] = {}
    if len(ready) > 1 and hasattr(method, "register_batch"):
        seed_everything(stable_seed(seed, ready[0][0]["sample_id"]))
        t0 = time.perf_counter()
        try:
            results = method.register_batch([sample.problem for _, sample in ready])
        except _NOT_THE_SAMPLES_FAULT:
            raise
        except Exception:  # noqa: BLE001 - one bad problem: each registers alone below
            results = None
        if results is not None:
            share = (time.perf_counter() - t0) / len(ready)
            scored = {
                row["sample_id"]: _scored(row, sample, result, share) for (row, sample), result in zip(ready, results)
            }
    return [
        row
        if sample is None
        else _with_estimate_facts(
            facts, dataset, scored.get(row["sample_id"]) or _register_one(method, row, sample, seed), sample
        )
        for row, sample in loaded
    ]
