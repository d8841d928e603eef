"""The product and its studies apart: ``results/`` holds outputs and ``results/make_results.sh``
only, every study under ``experiments/`` has a README with the five sections, and every script
``results/make_results.sh`` calls exists."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SECTIONS = ("Question", "Split", "Choice", "Results", "Rerun")


def scripts_in_results(repo: Path) -> list[str]:
    """Every ``.py`` file and every ``.sh`` file but ``results/make_results.sh`` under ``results/``."""
    return sorted(
        p.relative_to(repo).as_posix()
        for p in (repo / "results").rglob("*")
        if p.is_file() and (p.suffix == ".py" or (p.suffix == ".sh" and p != repo / "results" / "make_results.sh"))
    )


def studies_without_readme(repo: Path) -> list[str]:
    """``experiments/<study>/`` folders whose README.md is missing or lacks one of the five
    ``## <section>`` headings (named with what is missing)."""
    bad = []
    for folder in sorted(
        p for p in (repo / "experiments").iterdir() if p.is_dir() and not p.name.startswith((".", "_"))
    ):
        readme = folder / "README.md"
        if not readme.is_file():
            bad.append(f"{folder.name}: no README.md")
            continue
        headings = set(re.findall(r"^## (.+?)\s*$", readme.read_text(), flags=re.M))
        missing = [s for s in SECTIONS if s not in headings]
        if missing:
            bad.append(f"{folder.name}: README.md lacks {', '.join(missing)}")
    return bad


def test_results_holds_no_script_but_make_results():
    assert scripts_in_results(REPO) == []


def test_every_study_has_a_readme_with_the_five_sections():
    assert (REPO / "experiments" / "README.md").is_file()
    assert studies_without_readme(REPO) == []


def studies_not_listed(repo: Path) -> list[str]:
    """``experiments/<study>/`` folders that ``experiments/README.md``'s table does not link."""
    index = (repo / "experiments" / "README.md").read_text()
    folders = (p for p in (repo / "experiments").iterdir() if p.is_dir() and not p.name.startswith((".", "_")))
    return sorted(f.name for f in folders if f"]({f.name}/README.md)" not in index)


def test_every_study_is_listed_in_the_experiments_index():
    assert studies_not_listed(REPO) == []


def test_the_checks_catch_a_stray_script_and_a_bare_study(tmp_path):
    (tmp_path / "results" / "dev").mkdir(parents=True)
    (tmp_path / "results" / "make_results.sh").write_text("")
    (tmp_path / "results" / "table.md").write_text("")
    assert scripts_in_results(tmp_path) == []
    (tmp_path / "results" / "dev" / "grid.py").write_text("")
    (tmp_path / "results" / "dev" / "make_grid.sh").write_text("")
    assert scripts_in_results(tmp_path) == ["results/dev/grid.py", "results/dev/make_grid.sh"]
    (tmp_path / "experiments" / "bare").mkdir(parents=True)
    (tmp_path / "experiments" / "half").mkdir()
    (tmp_path / "experiments" / "half" / "README.md").write_text("# x\n\n## Question\n\n## Split\n\n### Choice\n")
    assert studies_without_readme(tmp_path) == ["bare: no README.md", "half: README.md lacks Choice, Results, Rerun"]
    (tmp_path / "experiments" / "README.md").write_text("| [half](half/README.md) | q | c |\n")
    assert studies_not_listed(tmp_path) == ["bare"]


@pytest.mark.parametrize(
    "script",
    ["results/make_results.sh", *sorted(p.relative_to(REPO).as_posix() for p in (REPO / "experiments").rglob("*.sh"))],
)
def test_every_script_a_script_names_exists(script):
    """Every ``experiments/...`` or ``results/...`` path ending in .sh or .py that a script names is
    there (the studies call each other and make_results.sh calls them)."""
    text = (REPO / script).read_text()
    named = set(re.findall(r"\b((?:experiments|results)/[\w/.-]+\.(?:sh|py))\b", text))
    # for script in a b c; do ... bash experiments/<study>/$script.sh
    for names, folder in re.findall(
        r"for script in ([\w ]+); do[^\n]*\n[^\n]*?\b(experiments/[\w/]+)/\$script\.sh", text
    ):
        named |= {f"{folder}/{n}.sh" for n in names.split()}
    missing = sorted(n for n in named if not (REPO / n).is_file())
    assert missing == [], f"{script} names {missing}"
