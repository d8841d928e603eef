"""``run -> export -> score`` gives back the run's own errors on the shared YCB-V frames, with any
subset of the targets missing (issue 23).

Property: for a run of a method on the shared YCB-V frames, exported as a BOP results CSV, every
subset of the exported estimates (in any order) scores
to the run's own per-sample errors for the estimates kept, and to misses ("no prediction",
180 degrees) for the ones left out and for the run's failed samples. With three samples every
subset is tried (8 of them). ``bench score`` with BOP's metrics (no VSD: it renders) is run once
on a subset that misses a target: the others are matched, the missing one is a miss, nothing
crashes.

The default suite runs it for ICP; every method is slow-marked (``make test-slow``).
"""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from catpose.bench.cli import main as bench
from catpose.bench.interop.prediction_io import read_predictions
from catpose.bench.interop.score import gt_rows_from_run, score_predictions
from catpose.bench.run.evaluate import recompute_row_errors
from catpose.bench.run.rundir import latest_rows, read_rows

LIMIT = 3


def run_and_export(method: str, shared_data: Path, tmp_path: Path) -> tuple[Path, Path]:
    """``bench run`` (a child process, as a user runs it) and ``bench export``: (run dir, CSV)."""
    root = shared_data / "bop" / "ycbv"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "catpose.bench.cli",
            "run",
            f"method={method}",
            "dataset=ycbv",
            f"dataset.root={root}",
            f"limit={LIMIT}",
            "progress=false",
            "print_summary=false",
            "threads=1",
            f"output_root={tmp_path / 'out'}",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=900,
        env=dict(os.environ, HYDRA_FULL_ERROR="0"),
    )
    if r.returncode == 2 and "is not importable" in r.stderr:  # teaserpp without TEASER++'s bindings
        pytest.skip(r.stderr.strip().splitlines()[-1])
    assert r.returncode == 0, r.stderr[-3000:]
    (run_dir,) = [p.parent for p in (tmp_path / "out").rglob("samples.jsonl")]
    csv = tmp_path / f"{method}_ycbv-test.csv"
    assert bench(["export", str(run_dir), "--out", str(csv)]) == 0
    return run_dir, csv


def check_every_subset(run_dir: Path, csv: Path, tmp_path: Path) -> int:
    """The property of the module docstring over every subset of the exported lines; returns how
    many subsets were checked."""
    own = {r["sample_id"]: recompute_row_errors(r) for r in latest_rows(run_dir / "samples.jsonl")}
    gt_rows = gt_rows_from_run(run_dir)[0]
    header, *lines = csv.read_text().splitlines()
    sample_of = {
        (int(i["scene_id"]), int(i["im_id"]), int(i["obj_id"])): r["sample_id"] for r in gt_rows for i in [r["info"]]
    }
    line_samples = [sample_of[tuple(int(x) for x in line.split(",")[:3])] for line in lines]
    rng = np.random.default_rng(0)
    checked = 0
    for n in range(len(lines) + 1):
        for keep in itertools.combinations(range(len(lines)), n):
            order = rng.permutation(list(keep)) if keep else []
            part = tmp_path / f"part{checked}_ycbv-test.csv"
            part.write_text("\n".join([header, *[lines[k] for k in order]]) + "\n")
            kept_samples = {line_samples[k] for k in keep}
            for row in score_predictions(read_predictions(part), gt_rows, "again"):
                sid = row["sample_id"]
                if sid in kept_samples:
                    assert row["status"] == "ok", (sid, row["error"])
                    assert row["err_deg"] == pytest.approx(own[sid]["err_deg"], abs=1e-4), sid
                    assert row["trans_err"] == pytest.approx(own[sid]["trans_err"], rel=1e-5, abs=1e-7), sid
                else:  # left out of the file, or failed in the run: a miss
                    assert row["status"] == "failed" and row["error"] == "no prediction" and row["err_deg"] == 180.0
            checked += 1
    return checked


def check_score_command_with_a_missing_target(run_dir: Path, csv: Path, tmp_path: Path, capsys) -> None:
    """``bench score`` end to end (BOP metrics without VSD) on the export less its first line."""
    header, first, *rest = csv.read_text().splitlines()
    part = tmp_path / "missing_ycbv-test.csv"
    part.write_text("\n".join([header, *rest]) + "\n")
    out = tmp_path / "scored"
    capsys.readouterr()
    assert bench(["score", str(part), "--gt", str(run_dir), "--out", str(out), "--no-vsd"]) == 0
    text = capsys.readouterr().out
    n_run = len(read_rows(run_dir / "samples.jsonl"))
    assert f"{len(rest)} prediction rows; {len(rest)} of {n_run} samples scored" in text
    header_line = json.loads((out / "bop_errors.jsonl").read_text().splitlines()[0])["header"]
    assert header_line["matched"] == len(rest)  # every estimate matched its target, the missing one is a miss
    assert header_line["targets"] > len(rest)  # the split's other targets: misses too, as in bop_toolkit
    misses = [json.loads(x) for x in (out / "bop_errors.jsonl").read_text().splitlines()[1:]]
    assert all(r["adds"] == float("inf") for r in misses if not r["matched"])


@pytest.mark.slow  # > 5 s: make test-slow
def test_icp_round_trip_with_every_subset_of_targets_missing(shared_data: Path, tmp_path: Path, capsys):
    run_dir, csv = run_and_export("icp", shared_data, tmp_path)
    assert check_every_subset(run_dir, csv, tmp_path) == 2 ** len(csv.read_text().splitlines()[1:])
    check_score_command_with_a_missing_target(run_dir, csv, tmp_path, capsys)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ours", "fgr", "ransac", "teaser", "teaserpp"])
def test_every_method_round_trips_with_every_subset_of_targets_missing(method: str, shared_data: Path, tmp_path: Path):
    run_dir, csv = run_and_export(method, shared_data, tmp_path)
    n_lines = len(csv.read_text().splitlines()) - 1
    assert check_every_subset(run_dir, csv, tmp_path) == 2**n_lines
