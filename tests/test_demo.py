"""``make demo`` prints the README's first table: ICP and ours on the embedded synthetic set under
the portable numeric profile, compared with ``results/report/tables/gt_model_summary.csv``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from catpose.bench.report import demo
from catpose.bench.run.environment import cpu_flags, portable_profile

REPO = Path(__file__).resolve().parents[1]
HEADER = "Methods,Mean° ↓,Med.° ↓,@10 ↑,@30 ↑,L_T ↓,time [s] ↓,failed ↓\n"


def test_differences_ignore_time_and_name_each_cell():
    quoted = HEADER + "ICP,14.248671191020852,0.247,0.9166666666666666,0.9166666666666666,0.364,1.77,0.0\n"
    assert (
        demo.differences(
            HEADER + "ICP,14.248671191020852,0.247,0.9166666666666666,0.9166666666666666,0.364,9.9,0\n", quoted
        )
        == []
    )
    moved = HEADER + "ICP,10.524,0.247,0.9375,0.9166666666666666,0.364,1.77,0\n"
    assert demo.differences(moved, quoted) == [
        "ICP Mean° ↓: 10.524 here, 14.249 quoted",
        "ICP @10 ↑: 0.938 here, 0.917 quoted",
    ]
    assert demo.differences(HEADER + "RPM-Net,1,1,1,1,1,1,0\n", quoted) == ["RPM-Net: no row in the quoted table"]


def test_the_demo_runs_under_the_portable_profile_and_says_so():
    described, env = demo.profile_env(native=False)
    if "avx2" in cpu_flags():
        assert described.startswith("portable (OPENBLAS_CORETYPE=Haswell") and env["OPENBLAS_CORETYPE"] == "Haswell"
        assert all(env[k] == v for k, v in portable_profile().items())
    described, env = demo.profile_env(native=True)
    assert described.startswith("native") and env.get("OPENBLAS_CORETYPE") == os.environ.get("OPENBLAS_CORETYPE")


@pytest.mark.slow
def test_make_demo_prints_the_readme_table(tmp_path: Path):
    """The whole demo (2 methods x 48 views), into a scratch output root: its rows are the README's
    quoted rows in every error column (the time column is this machine's)."""
    if "avx2" not in cpu_flags():
        pytest.skip("the portable profile needs an x86-64 CPU with AVX2")
    r = subprocess.run(
        [sys.executable, "-m", "catpose.bench.report.demo", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=3600,
        cwd=REPO,
        env=dict(os.environ, HYDRA_FULL_ERROR="0"),
    )
    assert r.returncode == 0, (r.stdout[-3000:], r.stderr[-3000:])
    assert "make demo: numeric profile: portable (" in r.stdout
    assert "agree with the README's table" in r.stdout
    per_category, pooled = r.stdout.index("**Per category (gt_model)**"), r.stdout.index("**All categories pooled")
    assert per_category < pooled and all(c in r.stdout[per_category:pooled] for c in ("Airplane", "Mug", "Plate"))
    table = r.stdout[pooled:]
    assert "| ICP | " in table and "| Ours | " in table


@pytest.mark.slow  # two bench runs of ICP: ~30 s
def test_the_demo_prints_a_table_per_category_and_the_pooled_one(tmp_path: Path, capsys, monkeypatch):
    """The paper's per-category layout above the pooled table (issue 61: only the pooled one was left)."""
    overrides = [
        "method=icp",
        "dataset=synthetic",
        "dataset.categories=[mug,can]",
        "dataset.instances_per_category=1",
        f"output_root={tmp_path}",
    ]
    r = subprocess.run(
        [sys.executable, "-m", "catpose.bench.cli", "run", *overrides, "progress=false", "print_summary=false"],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=REPO,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    from catpose.bench.run.config import compose
    from catpose.bench.run.rundir import run_dir_for

    monkeypatch.setattr(demo, "run_methods", lambda out, env: [run_dir_for(compose(overrides), overrides)])
    assert demo.main(["--out", str(tmp_path / "demo"), "--quoted", str(tmp_path / "none.csv")]) == 0
    out = capsys.readouterr().out
    assert out.index("**Per category (gt_model)**") < out.index("**All categories pooled (gt_model)**"), out
    header = next(line for line in out.splitlines() if line.startswith("| Methods | Metric |"))
    assert "Can" in header and "Mug" in header, header
