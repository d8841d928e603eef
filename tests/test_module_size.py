"""The module-size rule of docs/architecture.md: a source module over 400 lines (as ``ruff format``
lays it out) says at the top of its docstring why it is one module, in a sentence with "kept whole
because"; tests are exempt (a test file is a list of cases)."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SOURCES = ("bench", "methods", "datasets", "src/catpose", "configs")
LIMIT = 400


def too_long_without_reason(root: Path) -> list[str]:
    """Modules under ``root``'s source folders longer than :data:`LIMIT` lines whose module
    docstring does not say "kept whole because"."""
    found = []
    for folder in SOURCES:
        for path in sorted((root / folder).rglob("*.py")):
            text = path.read_text()
            if text.count("\n") <= LIMIT:
                continue
            doc = ast.get_docstring(ast.parse(text)) or ""
            if "kept whole because" not in " ".join(doc.lower().split()):
                found.append(f"{path.relative_to(root)}: {text.count(chr(10))} lines")
    return found


def test_long_modules_say_why_they_are_kept_whole():
    found = too_long_without_reason(REPO)
    assert not found, f"modules over {LIMIT} lines without 'kept whole because ...' in their docstring:\n" + "\n".join(
        found
    )


def test_the_rule_finds_a_long_module_and_accepts_a_reason(tmp_path):
    (tmp_path / "methods").mkdir()
    body = "x = 1\n" * (LIMIT + 1)
    (tmp_path / "methods" / "long.py").write_text('"""A long module."""\n' + body)
    (tmp_path / "methods" / "kept.py").write_text('"""A long module, kept whole\nbecause it is one loop."""\n' + body)
    (tmp_path / "methods" / "short.py").write_text('"""Short."""\nx = 1\n')
    assert too_long_without_reason(tmp_path) == [f"methods/long.py: {LIMIT + 2} lines"]
