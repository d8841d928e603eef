"""The speed tables the docs quote are made from bench perf's and the GPU check's CSVs, rounded,
nothing measured (experiments/speed/summary.py)."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import pytest

from catpose.errors import DatasetError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_module  # noqa: E402

pytestmark = pytest.mark.experiment

summary = study_module("experiments/speed/summary.py")

PERF = (
    "method,n,median_s,mean_s,p90_s,ratio_to_fgr,warmup_s,source,repeat,device,batch,threads,load_before,"
    "load_after,cpus,peak_rss_mb\n"
    'ours,36,0.04806,0.0483,0.05825,1.2314,3.0,"synthetic (gt_model, seed 0)",3,cpu,1,1,0.63,1.12,2,758.0\n'
    'fgr,36,0.03903,0.0399,0.06001,1.0,0.56,"synthetic (gt_model, seed 0)",3,cpu,1,1,0.63,1.12,2,758.0\n'
)
STAGES = "method,stage,median_s,mean_s\nours,descriptors,0.00882,0.0081\nours,refinement,0.01512,0.016\n"
GPU = (
    "device,batch,ms_per_problem,problems_per_s,max_rot_diff_deg_vs_cpu64,dtype,name,torch\n"
    "cuda,16,1.6534,604.8,0.00317,float32,NVIDIA H200,2.11.0\n"
)


def test_tables_from_the_csvs(summary, tmp_path: Path):
    (tmp_path / "perf_synthetic.csv").write_text(PERF)
    (tmp_path / "perf_synthetic_stages.csv").write_text(STAGES)
    (tmp_path / "perf_synthetic_times.csv").write_text("method,call,seconds\nours,0,0.05\n")  # not a problem set
    (tmp_path / "gpu_solver_h200.csv").write_text(GPU)
    written = summary.write_tables(tmp_path)
    assert [p.name for p in written] == ["speed.md", "stages.md", "gpu.md"]
    speed = (tmp_path / "speed.md").read_text()
    assert "| synthetic (gt_model, seed 0) | ours | 1 | 36 | 0.048 | 0.058 | 1.23 | 0.63 / 1.12 | 2 | 758 |" in speed
    assert "| synthetic (gt_model, seed 0) | fgr | 1 | 36 | 0.039 | 0.060 | 1.00 |" in speed
    stages = (tmp_path / "stages.md").read_text()
    assert "| stage | synthetic |" in stages and "| refinement | 0.0151 |" in stages
    assert (
        "| gpu_solver_h200.csv | NVIDIA H200 | 16 | 1.65 | 0.00317 | float32 | 2.11.0 |"
        in (tmp_path / "gpu.md").read_text()
    )


def test_the_threads_column_labels_each_row(summary, tmp_path: Path):
    """A row measured with ``bench perf --threads 2`` says 2; a CSV without the column says ``-``."""
    import pandas as pd

    (tmp_path / "perf_synthetic.csv").write_text(PERF.replace(",cpu,1,1,", ",cpu,1,2,"))
    old = pd.read_csv(io.StringIO(PERF.replace("synthetic", "ycbv"))).drop(columns="threads")
    old.to_csv(tmp_path / "perf_ycbv.csv", index=False)
    speed = summary.speed_table(tmp_path)
    assert "| synthetic (gt_model, seed 0) | ours | 2 | 36 | 0.048 |" in speed
    assert "| ycbv (gt_model, seed 0) | ours | - | 36 | 0.048 |" in speed


def test_no_csv_is_one_line(summary, tmp_path: Path):
    with pytest.raises(DatasetError, match="has no perf_<set>.csv or gpu_solver_"):
        summary.write_tables(tmp_path)


def test_committed_tables_are_the_committed_csvs(summary, repo_root: Path, tmp_path: Path):
    """results/perf/*.md are what the summary makes of results/perf/*.csv today."""
    import shutil

    for f in (repo_root / "results" / "perf").glob("*.csv"):
        shutil.copy(f, tmp_path / f.name)
    for p in summary.write_tables(tmp_path):
        assert p.read_text() == (repo_root / "results" / "perf" / p.name).read_text(), p.name
