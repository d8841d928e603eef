"""The installed package: one import root, configs found from a non-editable wheel, fast CLI help."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _run(args, **kw):
    return subprocess.run(args, capture_output=True, text=True, timeout=600, **kw)


def test_import_root_and_no_top_level_shadowing():
    import catpose.bench
    import catpose.datasets
    import catpose.methods

    assert Path(catpose.datasets.__file__).parent.name == "datasets"
    # the repo's top-level folders are not importable as `datasets` / `methods` / `bench`
    probe = (
        "import importlib.util, sys; bad = [m for m in ('datasets', 'methods', 'bench', 'configs') "
        "if (s := importlib.util.find_spec(m)) and str(s.origin or s.submodule_search_locations)"
        f".startswith({str(REPO)!r})]; print(bad); sys.exit(1 if bad else 0)"
    )
    r = _run([sys.executable, "-c", probe], cwd="/")
    assert r.returncode == 0, r.stdout + r.stderr


def test_every_bench_wing_is_a_declared_package():
    """pyproject lists the packages one by one; a wing missing there would still reach the wheel as
    *data* (setuptools warns that this stops), so the list itself is checked."""
    tomllib = pytest.importorskip("tomllib")
    packages = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    wings = {f"catpose.bench.{p.parent.name}" for p in (REPO / "bench").glob("*/__init__.py")}
    assert wings and wings <= packages, sorted(wings - packages)
    # every config group folder too: one missing is packed as data with a BuildBackendWarning each
    groups = {
        "catpose.configs." + ".".join(p.relative_to(REPO / "configs").parts)
        for p in (REPO / "configs").rglob("*")
        if p.is_dir() and "__pycache__" not in p.parts
    }
    assert groups and groups <= packages, sorted(groups - packages)


def test_wheel_installs_and_hydra_finds_its_configs(tmp_path):
    r = _run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(tmp_path / "w"),
            str(REPO),
        ]
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert "BuildBackendWarning" not in r.stdout + r.stderr, (r.stdout + r.stderr)[-2000:]
    wheel = next((tmp_path / "w").glob("catpose-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert "catpose/configs/run.yaml" in names and "catpose/configs/method/icp.yaml" in names
    assert "catpose/bench/run/runner.py" in names and "catpose/datasets/render.py" in names
    # every module of bench/ (its wings included: pyproject lists them one by one) is in the wheel
    sources = sorted(
        f"catpose/bench/{p.relative_to(REPO / 'bench').as_posix()}"
        for p in (REPO / "bench").rglob("*.py")
        if "__pycache__" not in p.parts
    )
    assert len(sources) > 40 and [s for s in sources if s not in names] == []
    assert not any(n.startswith(("datasets/", "methods/", "bench/")) for n in names)
    target = tmp_path / "site"
    r = _run([sys.executable, "-m", "pip", "install", "--no-deps", "--target", str(target), str(wheel)])
    assert r.returncode == 0, r.stderr[-2000:]
    probe = """
import catpose, catpose.bench.run.config as rc
import catpose.bench.cli, catpose.bench.protocols, catpose.bench.report.tables, catpose.bench.interop.score
import catpose.bench.regress.run_suites, catpose.bench.perf.registration, catpose.bench.category.template_medoids
import catpose.bench.real.suite, catpose.bench.scoring.bop_eval, catpose.api
from hydra import compose, initialize_config_module
assert catpose.__file__.startswith(TARGET), catpose.__file__
assert 'icp' in rc.available('method') and 'gt_model' in rc.available('protocol')
with initialize_config_module(config_module='catpose.configs', version_base='1.3'):
    cfg = compose(config_name='run', overrides=['method=icp'])
assert cfg.method._target_ == 'catpose.methods.icp.ICP', cfg.method
print('ok')
""".replace("TARGET", repr(str(target)))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    # -S: skip site-packages' editable finder for catpose; the dependencies come back via PYTHONPATH order
    site = [p for p in sys.path if p.endswith("site-packages")]
    env["PYTHONPATH"] = os.pathsep.join([str(target), *site])
    r = _run([sys.executable, "-S", "-c", probe], cwd=str(tmp_path), env=env)
    assert r.returncode == 0 and "ok" in r.stdout, r.stdout + r.stderr[-3000:]


def test_help_is_instant_and_imports_nothing_heavy():
    probe = (
        "import sys; from catpose.bench.cli import main; main(['--help']); "
        "heavy = [m for m in ('torch', 'open3d', 'hydra', 'pandas', 'matplotlib') if m in sys.modules]; "
        "print(heavy); sys.exit(1 if heavy else 0)"
    )
    r = _run([sys.executable, "-c", probe])
    assert r.returncode == 0, r.stdout + r.stderr
    assert "bench run" in r.stdout
