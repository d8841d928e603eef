"""Figures in the README, ``docs/`` and the studies' READMEs are quotes of files under ``results/``,
kept identical.

A quote in a Markdown file is a block between two markers naming the file (and, optionally, which
of its Markdown tables)::

    <!-- quote: results/real/table.md (table) -->
    | method | ycbv: ... |
    ...
    <!-- end quote -->

Selectors: none (the whole file), ``table`` (its first Markdown table: the first run of lines
starting with ``|``, with a bold title line just above it), ``table N`` (the N-th). A quoted file
that does not exist yet is shown as a placeholder saying which command writes it.

    python tools/doc_quotes.py            # refresh every quote from its file
    python tools/doc_quotes.py --check    # exit 1 and name each quote that differs

``make results`` regenerates the files (``results/make_results.sh``) and then refreshes the quotes;
``tests/test_doc_quotes.py`` fails while a quote differs from its file.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
START = re.compile(r"^<!-- quote: (?P<path>\S+)(?: \((?P<sel>[^)]*)\))? -->$")
END = "<!-- end quote -->"
PLACEHOLDER = "*(not generated yet: `make results` writes `{path}`)*"


@dataclass(frozen=True)
class Quote:
    """One quote block of a Markdown file: the quoted path, the selector, the lines between the
    markers and where they are (``start``: the opening marker's line index)."""

    doc: Path
    path: str
    selector: str
    start: int
    end: int
    body: list[str]


def doc_files(repo: Path = REPO) -> list[Path]:
    """The Markdown files whose figures must be quotes: README.md, docs/*.md and the studies'
    READMEs (experiments/*/README.md)."""
    return [
        repo / "README.md",
        *sorted((repo / "docs").glob("*.md")),
        *sorted((repo / "experiments").glob("*/README.md")),
    ]


def find_quotes(doc: Path) -> list[Quote]:
    """Every quote block of ``doc`` (a marker without its end is an error naming the line)."""
    lines = doc.read_text().splitlines()
    out, k, fenced = [], 0, False
    while k < len(lines):
        if lines[k].lstrip().startswith("```"):  # a marker shown as an example in a code block is not a quote
            fenced = not fenced
        m = None if fenced else START.match(lines[k].strip())
        if m:
            try:
                end = next(j for j in range(k + 1, len(lines)) if lines[j].strip() == END)
            except StopIteration:
                raise ValueError(f"{doc}:{k + 1}: quote of {m.group('path')} has no '{END}'") from None
            out.append(Quote(doc, m.group("path"), (m.group("sel") or "").strip(), k, end, lines[k + 1 : end]))
            k = end
        k += 1
    return out


def select(text: str, selector: str) -> list[str]:
    """The lines of ``text`` a selector picks (see the module docstring)."""
    lines = text.rstrip("\n").splitlines()
    if not selector:
        return lines
    m = re.fullmatch(r"table(?: (\d+))?", selector)
    if not m:
        raise ValueError(f"unknown quote selector {selector!r}; use nothing, 'table' or 'table N'")
    want = int(m.group(1) or 1)
    blocks, k = [], 0
    while k < len(lines):
        if lines[k].startswith("|"):
            j = k
            while j < len(lines) and lines[j].startswith("|"):
                j += 1
            first = k - 2 if k >= 2 and lines[k - 1] == "" and re.fullmatch(r"\*\*.+\*\*", lines[k - 2]) else k
            blocks.append(lines[first:j])
            k = j
        k += 1
    if len(blocks) < want:
        raise ValueError(f"the file has {len(blocks)} Markdown table(s), the quote asks for table {want}")
    return blocks[want - 1]


def expected(quote: Quote, repo: Path = REPO) -> list[str]:
    """What the quote must hold: the selection of its file, or the placeholder when the file is absent."""
    path = repo / quote.path
    if not path.is_file():
        return [PLACEHOLDER.format(path=quote.path)]
    return select(path.read_text(), quote.selector)


def differing(repo: Path = REPO) -> list[str]:
    """``doc:line: quote of PATH ...`` for every quote that is not its file's selection."""
    bad = []
    for doc in doc_files(repo):
        for q in find_quotes(doc):
            if not q.path.startswith("results/"):
                bad.append(f"{doc.relative_to(repo)}:{q.start + 1}: quotes {q.path}, which is not under results/")
            else:
                try:
                    if q.body != expected(q, repo):
                        bad.append(
                            f"{doc.relative_to(repo)}:{q.start + 1}: the quote of {q.path} differs from the file"
                        )
                except ValueError as e:  # the selector asks for a table the file does not have
                    bad.append(f"{doc.relative_to(repo)}:{q.start + 1}: {q.path}: {e}")
    return bad


def refresh(repo: Path = REPO) -> list[Path]:
    """Rewrite every quote from its file; returns the docs that changed."""
    changed = []
    for doc in doc_files(repo):
        lines = doc.read_text().splitlines()
        for q in reversed(find_quotes(doc)):
            lines[q.start + 1 : q.end] = expected(q, repo)
        text = "\n".join(lines) + "\n"
        if text != doc.read_text():
            from catpose import atomic

            atomic.write_text(doc, text)
            changed.append(doc)
    return changed


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python tools/doc_quotes.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="only check; exit 1 when a quote differs from its file")
    args = ap.parse_args(argv)
    if args.check:
        bad = differing()
        print("\n".join(bad) if bad else "every quote is its file's")
        return 1 if bad else 0
    for doc in refresh():
        print(f"refreshed {doc.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main())
