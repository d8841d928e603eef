"""What a Hydra user expects of ``bench run``: the closest valid names and keys for a typo,
``hydra.run.dir`` (Hydra's folder only) / ``hydra.sweep.dir`` with ``.hydra/``, quiet runs without a
progress bar, ``hydra/job_logging`` writing into the run directory."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from catpose.bench.run.config import check_run_args, did_you_mean
from catpose.errors import ConfigError

BENCH = [sys.executable, "-m", "catpose.bench.cli"]
TINY = [
    "dataset=synthetic",
    "dataset.categories=[car]",
    "dataset.instances_per_category=1",
    "dataset.views_per_instance=1",
]


def bench(*args: str, cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, HYDRA_FULL_ERROR="0", **(env or {}))
    return subprocess.run([*BENCH, *args], capture_output=True, text=True, timeout=600, cwd=cwd, env=env)


def test_did_you_mean():
    assert did_you_mean("metod", ["method", "dataset", "seed"], lambda c: f"{c}=ours") == "did you mean `method=ours`?"
    assert did_you_mean("zzz", ["method"]) == ""


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["metod=ours"], "unknown key 'metod' (metod=ours); did you mean `method=ours`?"),
        (["method=our"], "unknown method 'our'; did you mean `method=ours`? available:"),
        (["protocol=gt_modle"], "did you mean `protocol=gt_model`?"),
        (["method=ours", "method.optimiser.lrr=0.1"], "did you mean `method.optimiser.lr=0.1`?"),
        (["method=ours", "method.optimisr.lr=0.1"], "did you mean `method.optimiser.lr=0.1`?"),
        # the key exists, in another config of the group than the default ICP: name it
        (["method.optimiser.lr=0.001"], "method icp has no method.optimiser; method ours has it: `method=ours"),
        (["dataset.nosuch=1"], "dataset has categories, "),
        (["seed.x=1"], "seed is a value, not a group of keys"),
        # a sweep: every combination of the swept group names is composed before the first job
        (["-m", "metod=ours,icp"], "did you mean `method=ours`?"),
        (["-m", "method=icp,ours", "method.optimiser.lr=0.001"], "in the sweep's job method=icp: unknown key"),
    ],
)
def test_unknown_names_and_keys_get_the_closest_valid_ones(argv, needle):
    with pytest.raises(ConfigError) as info:
        check_run_args(argv)
    assert needle in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_valid_sweeps_and_other_configs_pass_the_check():
    check_run_args(["-m", "method=icp,ours", "seed=0,1", "limit=range(1,3)"])
    check_run_args(["-m", "+experiment=optimiser"])  # rows compose themselves: Hydra judges them
    check_run_args(["-m", "method=ours", "method.optimiser.lr=0.001,0.01"])


@pytest.mark.slow  # > 5 s: make test-slow
def test_hydra_run_dir_holds_only_hydras_folder(tmp_path: Path):
    r = bench("run", "method=icp", *TINY, "hydra.run.dir=out/x", "output_root=runs", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    x = tmp_path / "out" / "x"
    assert {p.name for p in (x / ".hydra").iterdir()} == {"config.yaml", "hydra.yaml", "overrides.yaml"}
    assert not (x / "samples.jsonl").exists() and len(list((tmp_path / "runs").rglob("samples.jsonl"))) == 1


@pytest.mark.slow  # > 5 s: make test-slow
def test_hydra_sweep_dir_gets_hydra_folders_and_job_files(tmp_path: Path):
    r = bench("run", "-m", "method=icp", *TINY, "seed=0,1", "hydra.sweep.dir=sw", "print_summary=false", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    for job in ("0", "1"):
        record = json.loads((tmp_path / "sw" / job / "job.json").read_text())
        assert record["status"] == "ok" and Path(record["run_dir"]).is_dir()
        assert (tmp_path / "sw" / job / ".hydra" / "overrides.yaml").is_file()
    assert "table: bench table --sweep sw" in r.stderr


@pytest.mark.slow  # > 5 s: make test-slow
def test_job_logging_writes_into_the_run_directory(tmp_path: Path):
    r = bench("run", "method=icp", *TINY, "hydra/job_logging=default", "log_level=DEBUG", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    (run_dir,) = list(tmp_path.glob("outputs/*/*/*"))
    assert "sample car/000/v00: ok" in (run_dir / "run.log").read_text()
    assert (run_dir / ".hydra" / "config.yaml").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["outputs"]  # no log file in the working directory


@pytest.mark.slow  # > 5 s: make test-slow
def test_log_level_error_silences_the_progress_bar(tmp_path: Path):
    quiet = bench("run", "method=icp", *TINY, "log_level=ERROR", cwd=tmp_path)
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr
    shown = bench("run", "method=icp", *TINY, "seed=1", "log_level=ERROR", "progress=true", cwd=tmp_path)
    assert shown.returncode == 0 and "icp on synthetic" in shown.stderr  # asked for: kept
