"""The import rules hold for every module, and the checker finds a planted violation of each kind."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _import_rules import ROOTS, WINGS, Violation, allowed, check_tree  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def test_every_module_follows_the_import_rules():
    found = check_tree(REPO)
    assert not found, "imports against the rules (docs/architecture.md):\n" + "\n".join(map(str, found))


def test_every_wing_on_disk_has_rules_and_every_rule_a_wing():
    on_disk = {p.parent.name for p in (REPO / "bench").glob("*/__init__.py")}
    assert on_disk == set(WINGS)
    assert all(set(deps) <= set(WINGS) for deps in WINGS.values())


def test_wing_rules_have_no_cycle():
    def reaches(a: str, b: str, seen: frozenset = frozenset()) -> bool:
        return any(d == b or (d not in seen and reaches(d, b, seen | {d})) for d in WINGS[a])

    assert not [w for w in WINGS if reaches(w, w)]


def _plant(root: Path, files: dict[str, str]) -> None:
    for folder in ROOTS:
        (root / folder).mkdir(parents=True, exist_ok=True)
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_checker_finds_planted_violations(tmp_path):
    _plant(
        tmp_path,
        {
            "datasets/bad_loader.py": "from catpose.methods.icp import ICP\n",
            "methods/bad_method.py": "def f():\n    import catpose.bench.run.runner\n",  # inside a function
            "methods/bad_loader_use.py": "from catpose.datasets import synthetic\n",
            "src/catpose/bad_core.py": "from catpose.datasets.render import cast_rays\n",
            "bench/scoring/__init__.py": "",
            "bench/scoring/bad_up.py": "from catpose.bench.run import runner\n",  # scoring imports no wing
            "bench/run/__init__.py": "",
            "bench/run/bad_relative.py": "from ..report import tables\n",  # relative: catpose.bench.report.tables
            "bench/run/bad_cli.py": "from catpose.bench.cli import main\n",  # no wing imports the CLI
            "bench/report/__init__.py": "",
            "bench/report/fine.py": (
                "from catpose.bench.run.rundir import read_rows\nfrom catpose.bench import scoring\n"
                "import numpy\nfrom catpose.datasets import render\nfrom . import fine\n"
            ),
            "bench/cli.py": "from catpose.bench.report import fine\nimport catpose.bench.perf\n",  # the CLI: anything
            "datasets/fine.py": "from catpose.geometry import dot3\nfrom catpose.datasets import render\n",
            "src/catpose/api/bad.py": "from omegaconf import OmegaConf\nfrom catpose.bench.run import build\n",
        },
    )
    found = {(v.path, v.target) for v in check_tree(tmp_path)}
    assert found == {
        ("datasets/bad_loader.py", "catpose.methods.icp.ICP"),
        ("methods/bad_method.py", "catpose.bench.run.runner"),
        ("methods/bad_loader_use.py", "catpose.datasets.synthetic"),
        ("src/catpose/bad_core.py", "catpose.datasets.render.cast_rays"),
        ("bench/scoring/bad_up.py", "catpose.bench.run.runner"),
        ("bench/run/bad_relative.py", "catpose.bench.report.tables"),
        ("bench/run/bad_cli.py", "catpose.bench.cli.main"),
        ("src/catpose/api/bad.py", "omegaconf.OmegaConf"),
        ("src/catpose/api/bad.py", "catpose.bench.run.build"),
    }


@pytest.mark.parametrize(
    "source,target,ok",
    [
        ("bench.report", "bench.run", True),
        ("bench.run", "bench.report", False),
        ("bench.protocols", "bench.run", False),
        ("bench.perf", "bench.regress", False),
        ("bench.perf", "bench.run", True),
        ("bench.regress", "bench.perf", False),
        ("bench.interop", "bench.report", True),
        ("methods", "datasets", False),
        ("datasets", "methods", False),
        ("core", "bench.run", False),
        ("bench", "bench.real", True),
        ("bench.real", "bench", False),
    ],
)
def test_rules_as_documented(source, target, ok):
    assert allowed(source, target) is ok


def test_protocols_import_no_registration_code(tmp_path):
    """The protocols list problems and score answers: of the methods only the choice rules, and no
    Open3D, catpose.o3d or ICP kernel, even inside a function; other wings may (the runner computes
    the choice's facts through the method side)."""
    _plant(
        tmp_path,
        {
            "bench/protocols/__init__.py": "",
            "bench/protocols/fine.py": "from catpose.methods.choice_rules import choose\nfrom catpose.methods import choice_rules\n",
            "bench/protocols/bad.py": (
                "import open3d\nfrom catpose.o3d import o3d\nfrom catpose.methods.cross_check import CrossCheck\n"
                "def f():\n    from catpose.methods.template_choice import TemplateChoice\n"
                "    from catpose.point_to_plane_kernel import refine_many\n    import catpose.methods\n"
            ),
            "bench/run/__init__.py": "",
            "bench/run/fine.py": "from catpose.methods.template_choice import TemplateChoice\nimport open3d\n",
        },
    )
    found = {(v.path, v.target) for v in check_tree(tmp_path)}
    assert found == {
        ("bench/protocols/bad.py", "open3d"),
        ("bench/protocols/bad.py", "catpose.o3d.o3d"),
        ("bench/protocols/bad.py", "catpose.methods.cross_check.CrossCheck"),
        ("bench/protocols/bad.py", "catpose.methods.template_choice.TemplateChoice"),
        ("bench/protocols/bad.py", "catpose.point_to_plane_kernel.refine_many"),
        ("bench/protocols/bad.py", "catpose.methods"),
    }


def test_no_registration_words_in_the_protocols():
    """``grep -rn "o3d\\|icp" bench/protocols`` finds nothing: not even a docstring names them."""
    hits = [
        f"{p.relative_to(REPO)}:{n}"
        for p in sorted((REPO / "bench" / "protocols").rglob("*.py"))
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if "o3d" in line or "icp" in line
    ]
    assert not hits, hits


def test_violation_reads_as_one_line():
    assert (
        str(Violation("bench/run/x.py", 3, "bench.run", "catpose.bench.report.tables"))
        == "bench/run/x.py:3: bench.run imports catpose.bench.report.tables"
    )


def test_the_application_layer_and_its_lazy_export(tmp_path):
    """``catpose.api`` may use datasets and methods; no other core module may import it (only the
    package root's lazy ``catpose.register``), and it imports no part of the bench, nor Hydra."""
    _plant(
        tmp_path,
        {
            "src/catpose/__init__.py": "def __getattr__(name):\n    from catpose import api\n",
            "src/catpose/geometry.py": "import catpose.api\n",  # the core below the application layer
            "src/catpose/api/__init__.py": "from catpose.methods.ours import Ours\nfrom catpose.datasets import render\n",
            "src/catpose/api/bad.py": "from catpose.bench.report import tables\nfrom catpose.bench import cli\n"
            "from catpose.bench.run.build import build_from_config\nimport hydra\n",
        },
    )
    found = {(v.path, v.target) for v in check_tree(tmp_path)}
    assert found == {
        ("src/catpose/geometry.py", "catpose.api"),
        ("src/catpose/api/bad.py", "catpose.bench.report.tables"),
        ("src/catpose/api/bad.py", "catpose.bench.cli"),
        ("src/catpose/api/bad.py", "catpose.bench.run.build.build_from_config"),
        ("src/catpose/api/bad.py", "hydra"),
    }


def test_the_package_never_reaches_the_scripts_outside_it(tmp_path):
    """No module of the package imports ``experiments/``, ``tools/`` or ``tests/``, a script there by
    its own name (a sibling import after a ``sys.path`` insert), or loads a file by ``sys.path``,
    ``runpy`` or ``importlib``'s file loaders; the studies and tools themselves may import the package."""
    _plant(
        tmp_path,
        {
            "experiments/_lib/why_wrong.py": "from catpose.bench.run import runner\n",
            "experiments/speed/summary.py": "import catpose\n",
            "tools/doc_quotes.py": "",
            "bench/report/__init__.py": "",
            "bench/report/bad.py": (
                "import sys\nimport experiments._lib.why_wrong\nfrom tools import doc_quotes\n"
                "def f():\n    sys.path.insert(0, 'experiments/_lib')\n    import why_wrong\n"
            ),
            "methods/bad.py": "import runpy\nfrom importlib.util import spec_from_file_location\n",
            "datasets/bad.py": "import importlib.util\nm = importlib.util.spec_from_file_location('x', 'tools/x.py')\n",
            "bench/report/fine.py": "import sys\nimport summary_statistics\nprint(sys.argv)\n",
        },
    )
    found = {(v.path, v.line, v.target) for v in check_tree(tmp_path)}
    assert found == {
        ("bench/report/bad.py", 2, "experiments._lib.why_wrong"),
        ("bench/report/bad.py", 3, "tools.doc_quotes"),
        ("bench/report/bad.py", 5, "sys.path"),
        ("bench/report/bad.py", 6, "why_wrong"),
        ("methods/bad.py", 1, "runpy"),
        ("methods/bad.py", 2, "spec_from_file_location"),
        ("datasets/bad.py", 2, "spec_from_file_location"),
    }
