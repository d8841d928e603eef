"""experiments/speed/first_sample.py: the table of cold and warm first registrations (no timing is
asserted: only what is measured and how it is summarised)."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_module  # noqa: E402

pytestmark = pytest.mark.experiment

first_sample = study_module("experiments/speed/first_sample.py")


def _row(state, run, order, first, jit=1.0):
    return {
        "state": state,
        "run": run,
        "template_order": order,
        "template": f"t{order}",
        "import_s": 2.0,
        "build_s": 0.5,
        "load_s": 0.3,
        "jit_start_s": jit,
        "first_s": first,
        "second_s": 0.1,
        "jit_start_cpu_s": jit / 2,
        "first_cpu_s": first / 2,
        "second_cpu_s": 0.05,
        "source": "x",
    }


def test_medians_per_state_and_template_and_the_jit_start_counts_for_the_first_template_only(first_sample):
    rows = [_row("cold", r, o, f) for r, f in enumerate((3.0, 5.0, 4.0)) for o in (1, 2)]
    rows += [
        _row("warm", r, o, f, jit=j) for r, (f, j) in enumerate(((0.3, 0.8), (0.5, 1.2), (0.4, 1.0))) for o in (1, 2)
    ]
    table = first_sample.medians(rows)
    assert [(t["state"], t["template_order"]) for t in table] == [("cold", 1), ("cold", 2), ("warm", 1), ("warm", 2)]
    warm1, warm2 = table[2], table[3]
    assert warm1["runs"] == 3 and warm1["first_s"] == 0.4 and warm1["jit_start_s"] == 1.0
    assert warm1["first_sample_s"] == pytest.approx(1.4) and warm2["first_sample_s"] == pytest.approx(0.4)
    assert warm1["first_sample_cpu_s"] == pytest.approx(0.7) and warm2["jit_start_s"] == 0.0


@pytest.mark.slow
def test_first_sample_runs_new_processes_cold_then_warm(first_sample, tmp_path):
    out = tmp_path / "first.csv"
    assert first_sample.main(["--methods", "icp", "--templates", "2", "--repeat", "1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [(r["state"], r["template_order"]) for r in rows] == [
        ("cold", "1"),
        ("cold", "2"),
        ("warm", "1"),
        ("warm", "2"),
    ]
    assert all(float(r["first_s"]) > 0 and float(r["second_s"]) > 0 for r in rows)
    runs = list(csv.DictReader((tmp_path / "first_runs.csv").open()))
    assert len(runs) == 4 and runs[0]["template"] != runs[1]["template"]
    assert (tmp_path / "first.md").read_text().startswith("**First sample of a template in a new process**: icp")
