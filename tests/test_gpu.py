"""experiments/speed/gpu.py, the solver-only GPU check, on the CPU: one row per device and batch,
the float64 answer against itself (no timing is asserted)."""

from __future__ import annotations

import csv
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import run_study  # noqa: E402

pytestmark = pytest.mark.experiment


def test_solver_only_gpu_check_runs_on_cpu(tmp_path):
    pytest.importorskip("torch")
    perf_gpu = SimpleNamespace(**run_study("experiments/speed/gpu.py"))

    out = tmp_path / "gpu.csv"
    assert perf_gpu.main(["--devices", "cpu", "--batches", "1,3", "--repeat", "1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(open(out)))
    assert [r["batch"] for r in rows] == ["1", "3"]
    assert all(float(r["max_rot_diff_deg_vs_cpu64"]) < 1e-6 and float(r["ms_per_problem"]) > 0 for r in rows)
