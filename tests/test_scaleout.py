"""Scale-out: sweeps through Hydra launchers give the serial run's tables.

The serial reference is ``bench run -m`` with Hydra's basic launcher (one job after another in
one process). Launcher tests need the cluster extra (``make cluster``) and skip without it; the
failed-job tests need nothing beyond the default install.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = [sys.executable, "-m", "catpose.bench.cli"]
TINY = [
    "dataset=synthetic",
    "dataset.categories=[car,bottle]",
    "dataset.instances_per_category=1",
    "dataset.views_per_instance=2",
    "progress=false",
    "print_summary=false",
    "threads=1",
]
GRID = ["method=icp,fgr", "seed=0,1"]  # 2 methods x 2 seeds


def bench(*args: str, cwd: Path, timeout: int = 900) -> subprocess.CompletedProcess:
    env = dict(os.environ, HYDRA_FULL_ERROR="0", RAY_AUTH_MODE="disabled")
    return subprocess.run([*BENCH, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env)


def needs(plugin: str):
    found = (
        importlib.util.find_spec("hydra_plugins") is not None
        and importlib.util.find_spec(f"hydra_plugins.{plugin}") is not None
    )
    return pytest.mark.skipif(not found, reason=f"{plugin} is not installed (the cluster extra: make cluster)")


def table(root: Path, cwd: Path) -> str:
    r = bench("table", str(root), "--format", "csv", "--metrics", "mean,median,acc10,acc30,trans,n,failed", cwd=cwd)
    assert r.returncode == 0, r.stderr[-3000:]
    return r.stdout


def estimates(root: Path) -> dict[str, list]:
    """run directory name -> [(sample_id, T_est, status)] in file order."""
    from catpose.bench.run.rundir import latest_rows

    out = {}
    for p in sorted(root.glob("synthetic-*/*/*/samples.jsonl")):
        out[f"{p.parent.parent.name}/{p.parent.name}"] = [
            (r["sample_id"], r["T_est"], r["status"]) for r in latest_rows(p)
        ]
    return out


def sweep_dirs(root: Path) -> list[Path]:
    return sorted(p.parent for p in root.glob("multirun/*/*/multirun.yaml"))


@pytest.fixture(scope="module")
def serial(tmp_path_factory) -> Path:
    """The 2 x 2 grid through Hydra's basic launcher: the reference."""
    root = tmp_path_factory.mktemp("serial")
    r = bench("run", "-m", *GRID, *TINY, f"output_root={root}", cwd=root)
    assert r.returncode == 0, r.stderr[-3000:]
    return root


# ---------------------------------------------------------------------------------------------
# sweeps: directories, status files, exit codes


@pytest.mark.slow  # > 5 s: make test-slow
def test_each_sweep_gets_its_own_directory_and_a_failed_job_fails_it(tmp_path):
    # dataset=modelnet40 without dataset.root fails its job; the other job still runs
    args = ["-m", "method=icp", "dataset=synthetic,modelnet40", "limit=1", *TINY[1:], f"output_root={tmp_path}"]
    r = bench("run", *args, cwd=tmp_path)
    assert r.returncode == 2, r.stderr[-3000:]
    assert "1 of 2 jobs ok, 1 failed" in r.stderr and "Traceback" not in r.stderr
    (first,) = sweep_dirs(tmp_path)
    jobs = {j["job"]: j for j in (json.loads(p.read_text()) for p in first.glob("*/job.json"))}
    assert jobs[0]["status"] == "ok" and Path(jobs[0]["run_dir"], "samples.jsonl").is_file()
    assert jobs[1]["status"] == "failed" and "dataset.root" in jobs[1]["error"]
    r = bench("table", "--sweep", str(first), cwd=tmp_path)
    assert r.returncode == 2 and "job 1" in r.stderr and "failed" in r.stderr

    # a second sweep at once: sweep directories are named to the microsecond, so it gets its own
    r = bench("run", "-m", "method=icp", "limit=1", *TINY, f"output_root={tmp_path}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    second = [d for d in sweep_dirs(tmp_path) if d != first]
    assert len(second) == 1 and (first / "1" / "job.json").is_file()  # the first sweep is untouched


def test_unknown_or_missing_launcher_is_one_line(tmp_path):
    r = bench("run", "-m", "hydra/launcher=nosuch", "method=icp", cwd=tmp_path)
    assert r.returncode == 2 and "unknown hydra/launcher 'nosuch'" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.slow  # > 5 s: make test-slow
def test_every_experiment_names_its_sweep_and_table():
    from hydra import compose, initialize_config_module

    from catpose.bench.report.tables import LAYOUTS

    # the paper's tables (other experiment files, e.g. mn40r_*, are single runs on shared data)
    names = ["ablation", "one_template", "optimiser", "relative_real", "templates", "tyol"]
    folder = Path(__file__).resolve().parents[1] / "configs" / "experiment"
    assert all((folder / f"{n}.yaml").is_file() for n in names)
    with initialize_config_module("catpose.configs", version_base=None):
        for name in names:
            cfg = compose("run", overrides=[f"+experiment={name}"], return_hydra_config=True)
            assert cfg.hydra.job.name == name
            assert cfg.table.layout in LAYOUTS
            rows = str(cfg.hydra.sweeper.params["+row"]).split(",")
            for row in rows:  # every row composes with the experiment
                assert compose("run", overrides=[f"+experiment={name}", f"+row={row}"]).method.name


# ---------------------------------------------------------------------------------------------
# the same tables from every way of running


def _assert_sweep_equals_serial(launcher: str, serial: Path, tmp_path: Path) -> None:
    """The GRID sweep under ``hydra/launcher=launcher`` gives the serial sweep's table and estimates."""
    r = bench("run", "-m", f"hydra/launcher={launcher}", *GRID, *TINY, f"output_root={tmp_path}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert table(tmp_path, tmp_path) == table(serial, tmp_path)
    assert estimates(tmp_path) == estimates(serial)


@pytest.mark.slow
@needs("hydra_joblib_launcher")
def test_joblib_sweep_equals_serial(serial, tmp_path):
    _assert_sweep_equals_serial("local_procs", serial, tmp_path)
    (sweep,) = sweep_dirs(tmp_path)
    r = bench("table", "--sweep", str(sweep), "--format", "csv", cwd=tmp_path)
    assert r.returncode == 0 and r.stdout.count("\n") >= 5, r.stderr


@pytest.mark.slow
@needs("hydra_joblib_launcher")
def test_joblib_sweep_with_a_failed_job_exits_non_zero(tmp_path):
    r = bench(
        "run",
        "-m",
        "hydra/launcher=local_procs",
        "method=icp",
        "dataset=synthetic,modelnet40",
        "limit=1",
        *TINY[1:],
        f"output_root={tmp_path}",
        cwd=tmp_path,
    )
    assert r.returncode == 2 and "1 of 2 jobs ok, 1 failed" in r.stderr, r.stderr[-3000:]


@pytest.mark.slow
@needs("hydra_ray_launcher")
def test_local_ray_sweep_equals_serial(serial, tmp_path):
    # a local Ray with 2 CPUs (configs/hydra/launcher/ray_local.yaml); a failed job fails the sweep
    _assert_sweep_equals_serial("ray_local", serial, tmp_path)
    r = bench(
        "run",
        "-m",
        "hydra/launcher=ray_local",
        "method=icp",
        "dataset=synthetic,modelnet40",
        "limit=1",
        *TINY[1:],
        f"output_root={tmp_path / 'failing'}",
        cwd=tmp_path,
    )
    assert r.returncode == 2 and "1 failed" in r.stderr, r.stderr[-3000:]


@pytest.mark.slow
@needs("hydra_submitit_launcher")
def test_submitit_local_sweep_equals_serial(serial, tmp_path):
    # submitit's local executor: the Slurm path without Slurm (`make slurm-check` runs a real one)
    r = bench(
        "run",
        "-m",
        "hydra/launcher=submitit_local",
        "hydra.launcher.timeout_min=20",
        *GRID,
        *TINY,
        f"output_root={tmp_path}",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    assert table(tmp_path, tmp_path) == table(serial, tmp_path)
    assert estimates(tmp_path) == estimates(serial)


# The launcher presets compose in tests/test_configs.py (without their plugins too).
