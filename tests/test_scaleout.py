"""Scale-out: sweeps through Hydra launchers and sharded runs give the serial run's tables.

The serial reference is ``bench run -m`` with Hydra's basic launcher (one job after another in
one process). Launcher tests need the cluster extra (``make cluster``) and skip without it; the
shard and failed-job tests need nothing beyond the default install.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from catpose.errors import ConfigError, DatasetError

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
# shards: pure functions


def test_shards_partition_the_ids_in_order():
    from catpose.bench.run.merge import shard_ids

    ids = [f"s{i:02d}" for i in range(11)]
    for n in (1, 2, 3, 4, 11, 12):
        parts = [shard_ids(ids, i, n) for i in range(n)]
        assert sorted(sum(parts, [])) == ids  # every id exactly once
        assert parts == [shard_ids(ids, i, n) for i in range(n)]  # deterministic
        interleaved = [p[j] for j in range(max(map(len, parts))) for p in parts if j < len(p)]
        assert interleaved == ids  # round-robin restores the run order (what merge relies on)


@pytest.mark.parametrize(
    "shard, shards, needle",
    [
        (None, 4, "shards=4 needs shard=I"),
        (4, 4, "out of range"),
        (-1, 2, "out of range"),
        ("a", 2, "shard='a' is not an integer"),
        (0, 0, "N >= 1"),
    ],
)
def test_bad_shard_values_name_the_key(shard, shards, needle):
    from catpose.bench.run.merge import parse_shard

    with pytest.raises(ConfigError, match=needle):
        parse_shard(shard, shards)


def test_parse_shard_accepts_unsharded_and_sharded():
    from catpose.bench.run.merge import parse_shard

    assert parse_shard(None, 1) is None and parse_shard(0, 1) is None
    assert parse_shard(3, 4) == (3, 4) and parse_shard("1", "2") == (1, 2)


def test_merge_restores_order_and_names_a_missing_shard(tmp_path):
    from catpose.bench.run.merge import merged_rows, shard_ids, shard_meta_file, shard_samples_file, write_shard_meta

    ids = [f"x{i}" for i in range(7)]
    for i in range(3):
        mine = shard_ids(ids, i, 3)
        write_shard_meta(tmp_path, i, 3, mine, finished=True)
        # written in reverse order, and one sample twice (a retry): the last row counts
        rows = [{"sample_id": s, "status": "ok", "v": 1} for s in reversed(mine)] + [
            {"sample_id": mine[0], "status": "ok", "v": 2}
        ]
        (tmp_path / shard_samples_file(i, 3)).write_text("".join(json.dumps(r) + "\n" for r in rows))
    merged = merged_rows(tmp_path)
    assert [r["sample_id"] for r in merged] == ids
    assert [r["v"] for r in merged if r["sample_id"] in ("x0", "x1", "x2")] == [2, 2, 2]

    # issue 60: a shard file holding another shard's rows (copied over it) is named, not merged
    (tmp_path / shard_samples_file(1, 3)).write_bytes((tmp_path / shard_samples_file(0, 3)).read_bytes())
    with pytest.raises(DatasetError, match="holds 3 sample.s. that shard 1 of 3 does not list"):
        merged_rows(tmp_path)

    (tmp_path / shard_meta_file(1, 3)).unlink()
    with pytest.raises(DatasetError, match="shard 1 of 3 has not run; run it with shards=3 shard=1"):
        merged_rows(tmp_path)


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


@pytest.mark.slow
@pytest.mark.parametrize("shards", [2, 4])
def test_sharded_run_equals_serial_bit_for_bit(tmp_path, shards):
    serial_root, sharded_root = tmp_path / "serial", tmp_path / "sharded"
    r = bench("run", "method=icp", *TINY, f"output_root={serial_root}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    r = bench(
        "run",
        "-m",
        "method=icp",
        *TINY,
        f"shards={shards}",
        f"shard=range({shards})",
        f"output_root={sharded_root}",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    (run_dir,) = sharded_root.glob("synthetic-gt_model/icp/*")
    assert len(list(run_dir.glob("samples.shard-*-of-*.jsonl"))) == shards
    assert table(sharded_root, tmp_path) == table(serial_root, tmp_path)  # bench table merges the shards
    assert estimates(sharded_root) == estimates(serial_root)
    import pandas as pd

    serial_dir = next(serial_root.glob("synthetic-gt_model/icp/*"))
    merged, ref = (pd.read_csv(d / "summary.csv").drop(columns="median_runtime_s") for d in (run_dir, serial_dir))
    pd.testing.assert_frame_equal(merged, ref, check_exact=True)  # every statistic but wall time


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
