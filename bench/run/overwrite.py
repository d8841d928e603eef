"""No command writes into a run or a table it did not create.

The rules (docs/file-safety.md):

- ``bench score --out DIR`` (and :func:`~catpose.bench.run.rundir.write_run`) writes a new run
  directory. An existing non-empty ``DIR`` is refused unless ``--force``, which replaces it
  whole (the new run is built beside it and swapped in when complete); ``--out`` equal to the
  ``--gt`` run is refused even with ``--force``; an ``--out`` that is a file is refused.
- ``bench merge`` (and the automatic merge of ``bench table``) writes a sharded run's
  ``samples.jsonl``. It refuses, unless ``--force``, to replace a ``samples.jsonl`` holding rows
  the merge would drop (a serial run's samples that no shard lists).
- ``bench align --out TABLE`` refuses an existing table unless ``--force``; a table with rows
  marked ``verified`` is never overwritten, even with ``--force``: the estimate goes to a new
  file beside it (``<name>.new.csv``, ``<name>.new2.csv``, ...) and the command says so.
"""

from __future__ import annotations

import csv
from pathlib import Path

from catpose.errors import InvalidInputError

RUN_FILES = ("samples.jsonl", "run.json", "config.yaml")


def _describe(folder: Path) -> str:
    entries = sorted(p.name for p in folder.iterdir())
    if any(name in entries for name in RUN_FILES) or any(n.startswith("samples.shard-") for n in entries):
        shown = ([n for n in RUN_FILES if n in entries] + [n for n in entries if n.startswith("samples.shard-")])[:3]
        return f"a run ({', '.join(shown)}, ...)"
    return f"{len(entries)} other file(s) ({', '.join(entries[:3])}{', ...' if len(entries) > 3 else ''})"


def check_new_output(out: str | Path, force: bool = False, flag: str = "--out", protected: Path | None = None) -> None:
    """Refuse to write a new run directory at ``out`` over something (see the module docstring).

    ``protected``: a run that must never be replaced (``bench score``'s ``--gt``)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"{flag} {out} is a file; pass a folder (new or empty) for the run directory")
    if protected is not None and out.exists() and out.resolve() == Path(protected).resolve():
        raise InvalidInputError(
            f"{flag} {out} is the --gt run itself; pass another {flag} (the ground truth is "
            "never overwritten, not even with --force)"
        )
    if out.is_dir() and any(out.iterdir()) and not force:
        raise InvalidInputError(
            f"{flag} {out} already holds {_describe(out)}; pass a new {flag}, or add --force to replace it"
        )


def _verified_rows(path: Path) -> int:
    with open(path, newline="", encoding="utf-8", errors="replace") as fh:
        return sum(str(r.get("verified") or "").strip().lower() == "true" for r in csv.DictReader(fh))


def free_name(path: Path) -> Path:
    """``<stem>.new<suffix>``, else ``<stem>.new2<suffix>``, ... : the first that does not exist."""
    k = 1
    while True:
        candidate = path.with_name(f"{path.stem}.new{'' if k == 1 else k}{path.suffix}")
        if not candidate.exists():
            return candidate
        k += 1


def table_destination(out: str | Path, force: bool = False) -> tuple[Path, str | None]:
    """Where ``bench align --out`` may write: ``(path, note)`` (see the module docstring); the note
    says why another file than ``out`` is written (None when it is ``out``)."""
    out = Path(out)
    if not out.exists():
        return out, None
    if out.is_dir():
        raise InvalidInputError(f"--out {out} is a folder; pass the CSV file to write")
    n = _verified_rows(out)
    if n:
        new = free_name(out)
        return new, (
            f"{out} has {n} row(s) marked verified, which bench align never overwrites; the new estimate "
            f"goes to {new}: compare the two and copy rows across by hand"
        )
    if not force:
        raise InvalidInputError(
            f"--out {out} exists; pass another --out, or add --force to overwrite it (it has no row marked verified)"
        )
    return out, None
