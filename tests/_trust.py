"""Helpers of the file-safety tests (test_file_safety.py, test_scoring_inputs.py): a toy run's rows,
its config, a run directory written from rows, and the one-line error check."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

CFG = {
    "method": {"name": "ours", "_target_": "x.Y"},
    "dataset": {"name": "toy"},
    "protocol": {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"},
    "seed": 0,
}


def one_error_line(capsys, command: str) -> str:
    """The command's stderr, checked to be exactly one ``bench <command>: error:`` line."""
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and not ln.startswith("bench: warning")]
    assert len(err) == 1, err
    assert err[0].startswith(f"bench {command}: error: "), err[0]
    return err[0]


def rows(errors_deg: list[float], category: str = "mug") -> list[dict]:
    """Rows of a toy run: identity ground truth, estimates turned by the given angles about z."""
    out = []
    for k, e in enumerate(errors_deg):
        c, s = np.cos(np.radians(e)), np.sin(np.radians(e))
        T_est = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        out.append(
            {
                "sample_id": f"{category}/i{k}/v0",
                "group_id": f"{category}/i{k}/v0",
                "obs_id": f"{category}/i{k}/v0",
                "category": category,
                "instance_id": f"i{k}",
                "method": "ours",
                "dataset": "toy",
                "protocol": "gt_model",
                "seed": 0,
                "status": "ok",
                "error": "",
                "symmetry_axis": None,
                "T_est": T_est.ravel().tolist(),
                "T_gt": np.eye(4).ravel().tolist(),
                "err_deg": e,
                "trans_err": 0.0,
                "score": 0.1,
                "runtime_s": 0.5,
                "info": {},
                "extras": {},
            }
        )
    return out


def with_bop_ids(run_rows: list[dict]) -> list[dict]:
    """``run_rows`` as rows of BOP-layout data: BOP scene, image and object ids in each ``info``
    (what ``bench export`` needs)."""
    return [dict(r, info={**r["info"], "scene_id": 1, "im_id": k, "obj_id": 1}) for k, r in enumerate(run_rows)]


def write_run(
    out_dir: str | Path, rows: Sequence[dict], config: dict, info: dict | None = None, force: bool = False
) -> Path:
    """Write a run directory (``samples.jsonl``, ``config.yaml``, ``run.json``, summaries) from
    ``rows`` (the ``samples.jsonl`` schema) and ``config`` (a plain dict with ``method``, ``dataset``,
    ``protocol`` nodes and ``seed``), built aside and moved into place; an existing run or other
    non-empty folder at ``out_dir`` is refused unless ``force``. Returns ``out_dir``."""
    from catpose import atomic
    from catpose.bench.run.overwrite import check_output
    from catpose.bench.run.rundir import write_run_into

    out = Path(out_dir)
    check_output(out, "folder", force=force, replaces="run")
    with atomic.building_dir(out) as tmp:
        write_run_into(tmp, rows, config, info)
    return out
