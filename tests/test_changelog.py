"""CHANGELOG.md: newest first, and every entry (a ``## `` section) at most ten lines: what changed
for a user and the figures that matter; the measurements behind a change are in ``git log`` and the
studies' READMEs."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def entries(text: str) -> list[tuple[str, list[str]]]:
    """(heading, non-blank lines) of every ``## `` section."""
    out: list[tuple[str, list[str]]] = []
    for line in text.splitlines():
        if line.startswith("## "):
            out.append((line, []))
        elif out and line.strip():
            out[-1][1].append(line)
    return out


def test_every_entry_is_at_most_ten_lines():
    long = [f"{h} ({len(body)} lines)" for h, body in entries((REPO / "CHANGELOG.md").read_text()) if len(body) > 10]
    assert long == []


def test_entries_are_newest_first():
    dates = [re.match(r"## (\d{4}-\d{2}-\d{2})", h).group(1) for h, _ in entries((REPO / "CHANGELOG.md").read_text())]
    assert dates == sorted(dates, reverse=True)
