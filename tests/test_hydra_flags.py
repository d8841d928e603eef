"""Hydra's own command-line flags pass through ``bench run`` untouched (``--cfg``, ``--info``,
``--resolve``, ``--package``, ``--config-dir``, ``--config-name``, ``hydra.*`` overrides); the
one-line override check applies to the plain overrides only."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from catpose.bench.cli import main
from catpose.bench.run.config import check_run_args, split_hydra_args
from catpose.errors import ConfigError


@pytest.mark.parametrize(
    "argv, flags, overrides",
    [
        (["--cfg", "job"], ["--cfg", "job"], []),
        (["--cfg=all", "method=ours"], ["--cfg=all"], ["method=ours"]),
        (
            ["-c", "hydra", "--resolve", "-p", "method", "seed=1"],
            ["-c", "hydra", "--resolve", "-p", "method"],
            ["seed=1"],
        ),
        (["--info", "plugins"], ["--info", "plugins"], []),
        (["--info", "method=icp"], ["--info"], ["method=icp"]),  # --info's value is optional
        (["-i", "defaults-tree"], ["-i", "defaults-tree"], []),
        (
            ["--config-dir", "/x", "--config-name", "mine", "method=a"],
            ["--config-dir", "/x", "--config-name", "mine"],
            ["method=a"],
        ),
        (["-cd", "/x", "-cn=mine"], ["-cd", "/x", "-cn=mine"], []),
        (
            ["-m", "method=icp,ours", "hydra.job.name=x", "+experiment=optimiser"],
            ["-m"],
            ["method=icp,ours", "hydra.job.name=x", "+experiment=optimiser"],
        ),
        (["--hydra-help"], ["--hydra-help"], []),
        (["~method.foo", "--nosuchflag"], [], ["~method.foo", "--nosuchflag"]),  # Hydra reports unknown flags
    ],
)
def test_split_hydra_args(argv, flags, overrides):
    assert split_hydra_args(argv) == (flags, overrides)


def test_plain_overrides_still_checked_beside_flags():
    with pytest.raises(ConfigError, match="unknown method 'nosuch'"):
        check_run_args(["--cfg", "job", "method=nosuch"])
    with pytest.raises(ConfigError, match="unknown key 'datset'"):
        check_run_args(["--cfg", "job", "datset=x"])
    check_run_args(["--cfg", "job", "hydra.verbose=true", "hydra.job.name=x", "log_level=DEBUG"])
    # another config folder may add names the package does not have: Hydra judges them
    check_run_args(["--config-dir", "/somewhere", "method=mine"])


def _bench_run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["run", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_cfg_job_prints_the_composed_config(capsys):
    code, out, err = _bench_run(capsys, "--cfg", "job", "method=ours", "seed=3")
    assert code == 0, err
    cfg = yaml.safe_load(out)
    assert cfg["method"]["name"] == "ours" and cfg["seed"] == 3 and cfg["dataset"]["name"] == "synthetic"
    assert "hydra" not in cfg and cfg["log_level"] == "INFO"


def test_cfg_resolve_package_and_hydra_overrides(capsys):
    code, out, err = _bench_run(capsys, "--cfg", "job", "--resolve", "--package", "dataset", "seed=7")
    assert code == 0, err
    assert out.startswith("# @package dataset") and yaml.safe_load(out)["seed"] == 7  # ${seed} resolved
    code, out, err = _bench_run(capsys, "--cfg", "hydra", "hydra.job.name=renamed", "hydra.verbose=true")
    assert code == 0, err
    hydra_cfg = yaml.safe_load(out)["hydra"]
    assert hydra_cfg["job"]["name"] == "renamed" and hydra_cfg["verbose"] is True


def test_config_dir_adds_a_method(tmp_path: Path, capsys):
    (tmp_path / "method").mkdir()
    (tmp_path / "method" / "mine.yaml").write_text("name: mine\n_target_: catpose.methods.icp.ICP\nnum_starts: 3\n")
    code, out, err = _bench_run(capsys, "--config-dir", str(tmp_path), "--cfg", "job", "method=mine")
    assert code == 0, err
    assert yaml.safe_load(out)["method"] == {"name": "mine", "_target_": "catpose.methods.icp.ICP", "num_starts": 3}


def test_a_bad_override_beside_cfg_is_one_line(capsys):
    code, out, err = _bench_run(capsys, "--cfg", "job", "method=nosuch")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "unknown method 'nosuch'" in err


def test_info_plugins_lists_the_launchers():
    """In a subprocess: Hydra's plugin discovery is process-wide. The launchers of the cluster
    extra are listed when it is installed (``make cluster``)."""
    r = subprocess.run(
        [sys.executable, "-m", "catpose.bench.cli", "run", "--info", "plugins"],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, HYDRA_FULL_ERROR="0"),
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert "Installed Hydra Plugins" in r.stdout and "Launcher:" in r.stdout and "BasicLauncher" in r.stdout
    for module, launcher in (
        ("hydra_plugins.hydra_joblib_launcher", "JoblibLauncher"),
        ("hydra_plugins.hydra_submitit_launcher", "SlurmLauncher"),
        ("hydra_plugins.hydra_ray_launcher", "RayLauncher"),
    ):
        try:
            installed = importlib.util.find_spec(module) is not None
        except ImportError:
            installed = False
        assert (launcher in r.stdout) == installed, (launcher, installed)
