"""What the distribution declares: licence and citation files, dependencies for every platform,
optional extras that say how to install them, one CLI under two names."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
import tomllib

REPO = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]

#: (sys_platform, platform_machine) of the platforms PyPI has Open3D wheels for
PLATFORMS = [("linux", "x86_64"), ("linux", "aarch64"), ("darwin", "x86_64"), ("darwin", "arm64"), ("win32", "AMD64")]


def _requirements(names: set[str], platform: tuple[str, str]) -> list[str]:
    from packaging.requirements import Requirement

    env = {"sys_platform": platform[0], "platform_machine": platform[1], "python_version": "3.11"}
    out = []
    for text in PROJECT["dependencies"]:
        req = Requirement(text)
        if req.name in names and (req.marker is None or req.marker.evaluate(env)):
            out.append(req.name)
    return out


@pytest.mark.parametrize("platform", PLATFORMS, ids=lambda p: "-".join(p))
def test_exactly_one_open3d_on_every_platform(platform):
    found = _requirements({"open3d", "open3d-cpu"}, platform)
    assert found == (["open3d-cpu"] if platform == ("linux", "x86_64") else ["open3d"]), found


def test_licence_citation_and_declared_imports():
    assert (REPO / "LICENSE").read_text().startswith("MIT License")
    assert PROJECT["license"] == "MIT" and PROJECT["license-files"] == ["LICENSE"]  # SPDX expression (PEP 639)
    cff = (REPO / "CITATION.cff").read_text()
    assert "cff-version: 1.2.0" in cff and "arXiv:2209.14419" in cff and "preferred-citation:" in cff
    core = {d.split(">")[0].split("=")[0].split(";")[0].strip().lower() for d in PROJECT["dependencies"]}
    assert "pyyaml" in core  # `import yaml` in bench (templates, perf, regress)
    extras = PROJECT["optional-dependencies"]
    assert any(d.startswith("pot") for d in extras["test"])  # the exact EMD, PFH's reference in tests
    assert PROJECT["scripts"]["catpose"] == PROJECT["scripts"]["bench"] == "catpose.bench.cli:main"


def _names(requirements: list[str]) -> set[str]:
    from packaging.requirements import Requirement

    return {Requirement(r).name.lower() for r in requirements}


def test_a_plain_install_pulls_no_torch_and_nothing_gpl():
    """torch is the `torch` extra (its Linux wheel on PyPI is the CUDA build, with nvidia-* and
    triton); no extra that `make setup` installs brings GPL code (kmedoids was one: K-medoids is
    catpose's own PAM now)."""
    core, extras = _names(PROJECT["dependencies"]), PROJECT["optional-dependencies"]
    assert "torch" not in core and _names(extras["torch"]) == {"torch"}
    setup_extras = re.search(r'-e "\.\[([a-z,]+)\]"', (REPO / "Makefile").read_text()).group(1).split(",")
    assert {"torch", "test"} <= set(setup_extras)
    installed_by_setup = core.union(*(_names(extras[e]) for e in setup_extras))
    assert not {"kmedoids", "triton"} & installed_by_setup and not any(
        n.startswith("nvidia") for n in installed_by_setup
    )


def test_templates_need_no_optional_package(monkeypatch, tmp_path):
    """`bench templates` runs without kmedoids (which make setup no longer installs)."""
    from catpose.bench.category import template_medoids

    monkeypatch.setitem(sys.modules, "kmedoids", None)  # `import kmedoids` now raises ImportError
    out = tmp_path / "t.yaml"
    args = ["dataset=synthetic", "dataset.categories=[mug]", "dataset.instances_per_category=3"]
    assert template_medoids.main([*args, "--category", "mug", "--k", "2", "--points", "200", "--out", str(out)]) == 0
    assert out.is_file()


def test_missing_torch_is_one_line_naming_the_extra(monkeypatch):
    """Without torch: the configurations that need it stop in one line naming `catpose[torch]`,
    and the runner imports nothing of it for the ones that do not."""
    from catpose import extras
    from catpose.bench.run import runner

    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` now raises ImportError
    monkeypatch.setattr(extras, "installed", lambda module: module != "torch" and module in sys.modules)
    missing = str(extras.MissingExtra("torch"))
    assert "\n" not in missing and "needs torch" in missing and "pip install 'catpose[torch]'" in missing
    try:
        import torch  # noqa: F401
    except ImportError as e:
        message = runner._abort_message(e, "mug/000/v00")
    assert "catpose[torch]" in message and "install it, then re-run the same command" in message
    runner.import_heavy_libraries(modules=("torch",))  # skipped, not an abort
    extras.set_torch_threads(1)  # nothing to set
