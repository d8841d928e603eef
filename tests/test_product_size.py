"""The product's size ceiling (docs/architecture.md, "Conventions the layout keeps"): the Python in
``bench/``, ``methods/``, ``datasets/`` and ``src/`` may not grow past :data:`CEILING` lines, so a
change pays for what it adds by removing. The project's goal is :data:`GOAL`, and the
ceiling has reached it: it is never raised."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PRODUCT = ("bench", "methods", "datasets", "src")
GOAL = 25_000
CEILING = 25_000


def product_lines(root: Path) -> int:
    """Lines of every ``*.py`` file under ``root``'s product folders (as ``wc -l`` counts them)."""
    return sum(path.read_text().count("\n") for folder in PRODUCT for path in (root / folder).rglob("*.py"))


def test_the_product_stays_under_its_ceiling():
    lines = product_lines(REPO)
    assert lines <= CEILING, f"the product has {lines} lines, over its ceiling {CEILING}: remove what a change adds"


def test_the_ceiling_only_moves_towards_the_goal():
    assert GOAL <= CEILING


def test_the_count_sees_a_new_module(tmp_path):
    (tmp_path / "methods").mkdir()
    (tmp_path / "methods" / "x.py").write_text("a = 1\nb = 2\n")
    assert product_lines(tmp_path) == 2
