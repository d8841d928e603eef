"""What the distribution declares: licence and citation files, dependencies for every platform,
optional extras that say how to install them, one CLI under two names."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import tomllib

from catpose.errors import ConfigError

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
    assert "kmedoids" not in core  # GPL-3.0: optional
    extras = PROJECT["optional-dependencies"]
    assert any(d.startswith("kmedoids") for d in extras["kmedoids"]) and any(d.startswith("pot") for d in extras["pfh"])
    assert any(d.startswith("kmedoids") for d in extras["test"]) and any(d.startswith("pot") for d in extras["test"])
    assert PROJECT["scripts"]["catpose"] == PROJECT["scripts"]["bench"] == "catpose.bench.cli:main"


def test_templates_without_kmedoids_says_how_to_install_it(monkeypatch, tmp_path):
    from catpose.bench.category import template_medoids

    monkeypatch.setitem(sys.modules, "kmedoids", None)  # `import kmedoids` now raises ImportError
    with pytest.raises(ConfigError, match=r"pip install 'catpose\[kmedoids\]'") as info:
        template_medoids.main(["dataset=synthetic", "--category", "chair", "--out", str(tmp_path / "t.yaml")])
    assert "\n" not in str(info.value) and not (tmp_path / "t.yaml").exists()
