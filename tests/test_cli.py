"""End-to-end `bench` CLI: a tiny run, resume without work, one-line errors for bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pandas as pd
import pytest

BENCH = [sys.executable, "-m", "catpose.bench.cli"]
TINY = [
    "dataset=synthetic",
    "dataset.categories=[car,bottle]",
    "dataset.instances_per_category=1",
    "dataset.views_per_instance=2",
    "progress=false",
]


def bench(*args, cwd):
    env = dict(os.environ, HYDRA_FULL_ERROR="0")
    return subprocess.run([*BENCH, *args], capture_output=True, text=True, timeout=600, cwd=cwd, env=env)


@pytest.mark.slow  # > 5 s: make test-slow
def test_tiny_run_then_rerun_does_no_work(tmp_path):
    r = bench("run", "method=icp", *TINY, f"output_root={tmp_path}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "| car" in r.stdout and "| bottle" in r.stdout and "| all" in r.stdout
    run_dir = next(tmp_path.glob("synthetic-gt_model/icp/*"))
    assert json.loads((run_dir / "run.json").read_text())["n_run_now"] == 4
    first = pd.read_csv(run_dir / "summary.csv")
    assert list(first["category"]) == ["bottle", "car", "all"] and first["n"].tolist() == [2, 2, 4]

    r = bench("run", "method=icp", *TINY, f"output_root={tmp_path}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert json.loads((run_dir / "run.json").read_text())["n_run_now"] == 0
    pd.testing.assert_frame_equal(pd.read_csv(run_dir / "summary.csv"), first)
    assert len((run_dir / "samples.jsonl").read_text().splitlines()) == 4

    r = bench("evaluate", str(run_dir), cwd=tmp_path)
    assert r.returncode == 0 and "| all" in r.stdout, r.stderr


@pytest.mark.slow  # > 5 s: make test-slow
def test_multirun_sweep(tmp_path):
    r = bench("run", "-m", "method=icp", *TINY, "limit=1", "seed=0,1", f"output_root={tmp_path}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert sorted(p.name.split("-")[0] for p in tmp_path.glob("synthetic-gt_model/icp/*")) == ["seed0", "seed1"]


@pytest.mark.parametrize(
    "args, needle",
    [
        (["run", "method=nosuch"], "unknown method 'nosuch'; available:"),
        (["run", "dataset=nosuch"], "unknown dataset 'nosuch'; available:"),
        (["run", "protocol=nosuch"], "unknown protocol 'nosuch'; available:"),
        (["nosuch"], "unknown command 'nosuch'"),
        (["evaluate", "/nonexistent/run"], "is not a run directory"),
        (["run", "method=ours", "method.foo=1"], "unknown key 'method.foo' (method.foo=1): method has "),
        (["run", "datset=synthetic"], "unknown key 'datset' (datset=synthetic); did you mean `dataset=synthetic`?"),
        (["run", "metod=ours"], "did you mean `method=ours`?"),
        (["run", "method=our"], "unknown method 'our'; did you mean `method=ours`? available:"),
        (["run", "seed=[1"], "no viable alternative at input '[1'"),
    ],
)
def test_bad_names_give_one_line(tmp_path, args, needle):
    r = bench(*args, cwd=tmp_path)
    assert r.returncode == 2
    assert needle in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "Traceback" not in r.stderr


def test_missing_dataset_root_gives_one_line(tmp_path):
    r = bench("run", "method=icp", "dataset=modelnet40", f"dataset.root={tmp_path / 'nope'}", cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and str(tmp_path / "nope") in lines[0] and "Traceback" not in r.stderr, r.stderr


def test_missing_required_root_gives_one_line(tmp_path):
    r = bench("run", "method=icp", "dataset=bop", cwd=tmp_path)
    assert r.returncode == 2 and "dataset.root" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
