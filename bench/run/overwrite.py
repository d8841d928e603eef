"""No command writes into what it did not create: the one output rule (docs/file-safety.md).

Every command that writes where it is told (``--out``, ``--sheet``, ``--write``) makes an
:class:`Output` before any work, which applies :func:`check_output`: the target is no input and
lies inside none (nor inside a run directory, nor holds the current folder), not even with
``--force``; a file never replaces a folder nor a folder a file; an existing target needs
``--force``, and a table with rows marked ``verified`` (or its contact sheet, or a folder holding
runs or such tables) is never replaced; its folder must be writable. Files are then written
atomically (:mod:`catpose.atomic`), folders built beside their destination and moved into
place, and an ``OSError`` while writing is one line (:func:`output_errors`)."""

from __future__ import annotations

import contextlib
import csv
import errno
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

from catpose.errors import InvalidInputError

RUN_FILES = ("samples.jsonl", "run.json", "config.yaml")
SHEET_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


class Input(NamedTuple):
    """An input of a command: its path, what it is as the error names it (``the input run``), and
    whether it is only a folder searched for runs (an output may then lie inside it, beside them)."""

    path: Path
    what: str
    searched: bool = False


def is_run_dir(path: Path) -> bool:
    """Whether ``path`` is a run directory (``samples.jsonl`` in it)."""
    return (Path(path) / "samples.jsonl").is_file()


def runs_below(paths: Sequence[str | Path]) -> list[Path]:
    """The run directories given, or found below the folders given."""
    out: list[Path] = []
    for p in map(Path, paths):
        if is_run_dir(p):
            out.append(p)
        elif p.is_dir():
            out += sorted(q.parent for q in p.rglob("samples.jsonl"))
    return out


def input_runs(paths: Sequence[str | Path], what: str = "the input run") -> list[Input]:
    """The inputs of a command that reads run directories: every run given or found below the
    folders given (:func:`runs_below`), and the folders themselves."""
    found = [Input(p, what) for p in runs_below(paths)]
    given = [Input(Path(p), "the input folder", True) for p in paths if Path(p).is_dir() and not is_run_dir(Path(p))]
    return found + given


def absolute_path(path: str | Path) -> Path:
    """``path`` absolute, ``..`` and symbolic links resolved where they exist; a loop of symbolic
    links raises :class:`InvalidInputError` saying so (every command's check of one)."""
    try:
        return Path(os.path.abspath(Path(path).expanduser())).resolve()
    except (RuntimeError, OSError):  # Python < 3.13 raises RuntimeError on a loop
        raise InvalidInputError(f"{path} is a loop of symbolic links; pass the file or folder itself") from None


def verified_rows(path: Path) -> int:
    """Rows of a CSV marked ``verified=true`` (0 for anything that is not such a CSV)."""
    path = Path(path)
    if path.suffix.lower() != ".csv" or not path.is_file():
        return 0
    try:
        with open(path, newline="", encoding="utf-8", errors="replace") as fh:
            return sum(str(r.get("verified") or "").strip().lower() == "true" for r in csv.DictReader(fh))
    except (OSError, csv.Error):
        return 0


def check_not_input(out: str | Path, inputs: Sequence[Input] = (), flag: str = "--out") -> Path:
    """The first part of :func:`check_output`: ``out`` is no input, holds none and lies inside none
    (a folder only searched for runs may hold it); returns it as an absolute path."""
    if str(out).strip() == "":
        raise InvalidInputError(f"{flag} is empty; pass the file or folder to write")
    target = absolute_path(out)
    for path, what, searched in (Input(*i) for i in inputs):
        inp = absolute_path(path)
        if inp == target:
            why = f"is {what} itself; pass another {flag} (an input is never overwritten, not even with --force)"
        elif inp.is_relative_to(target):
            why = f"contains {what} {path}; pass an {flag} outside it (writing it would replace an input)"
        elif target.is_relative_to(inp) and not searched:
            why = f"lies inside {what} {path}; pass an {flag} outside it (no command writes into an input)"
        else:
            continue
        raise InvalidInputError(f"{flag} {out} {why}")
    return target


def check_output(
    out: str | Path,
    kind: str = "file",
    inputs: Sequence[Input] = (),
    force: bool = False,
    flag: str = "--out",
    replaces: str = "",
    allow: Path | None = None,
    example: str = "out.md",
) -> Path:
    """The output rule (see the module docstring) for writing ``out``; returns it as an absolute path.

    Args:
        out: what the command was told to write.
        kind: ``"file"`` or ``"folder"``.
        inputs: what the command reads (:data:`Input`; :func:`input_runs` for run directories).
        force: ``--force`` was given (an existing target may be replaced).
        flag: the option's name in messages (``--out``, ``--sheet``, ``--write``).
        replaces: for a folder, ``"run"`` when a run directory at ``out`` itself may be replaced
            with ``--force`` (``bench score`` writes runs); otherwise a run is never replaced.
        allow: a verified table's picture this command may redraw (``align.py --draw-only``).
        example: a file name the message suggests when a file's ``out`` is a folder.

    Raises:
        InvalidInputError: one line naming ``out``, what is in the way and the fix.
    """
    target = check_not_input(out, inputs, flag)
    shown = f"{flag} {out}"
    run = next((parent for parent in target.parents if is_run_dir(parent)), None)  # the run it lies inside
    if run is not None:
        raise InvalidInputError(
            f"{shown} lies inside the run directory {run}; pass an {flag} outside it "
            "(no command writes into a run it did not create)"
        )
    if kind == "folder" and absolute_path(Path.cwd()).is_relative_to(target):
        raise InvalidInputError(
            f"{shown} is the current folder or holds it; pass a new folder for the {flag} (replacing it would "
            "delete where you stand)"
        )
    blocking = next((p for p in reversed(target.parents) if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise InvalidInputError(f"{shown}: {blocking} is a file, not a folder; pass an {flag} in a folder")
    why = _in_the_way(target, kind, force, flag, replaces, allow, example) if target.exists() else None
    if why:
        raise InvalidInputError(f"{shown} {why}")
    existing = next(p for p in (target, *target.parents) if p.exists())
    folder = existing if existing.is_dir() and existing != target else existing.parent
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InvalidInputError(
            f"cannot write {flag} {out}: the folder {folder} is not writable; pass a writable folder"
        )
    return target


def _in_the_way(target: Path, kind: str, force: bool, flag: str, replaces: str, allow, example: str) -> str | None:
    """Why the existing ``target`` may not be replaced (the end of :func:`check_output`'s line), or None."""
    never = "not even --force does that: pass a new " + flag
    if kind == "file":
        if target.is_dir():
            return f"is a folder; pass the file to write, e.g. {target / example}"
        n = verified_rows(target)
        if n:
            return f"has {n} row(s) marked verified, which no command overwrites, not even with --force; pass another {flag}"
        table = target.with_suffix(".csv")  # the contact sheet of a verified table is its picture
        n = verified_rows(table) if target.suffix.lower() in SHEET_SUFFIXES else 0
        if n and (allow is None or absolute_path(allow) != target):
            return (
                f"is the contact sheet of {table}, which has {n} row(s) marked verified; pass "
                f"another {flag} (a verified table's picture is never overwritten)"
            )
        return None if force else f"exists; pass another {flag}, or add --force to replace it"
    if not target.is_dir():
        return "is a file; pass a folder (new or empty) to write"
    entries = sorted(p.name for p in target.iterdir())
    if not entries:
        return None
    from catpose.bench.run.rundir import in_use

    pid = in_use(target)
    if pid is not None:
        return (
            f"is a run that pid {pid} is still writing, which no command replaces, not even with --force; "
            f"pass a new {flag}, or wait for that run to finish"
        )
    if is_run_dir(target) and replaces != "run":
        return f"holds a run directory, which this command never replaces; pass a new {flag}"
    if not force:
        files = [n for n in RUN_FILES if n in entries]
        held = (
            f"a run ({', '.join(files)}, ...)"
            if files
            else (f"{len(entries)} other file(s) ({', '.join(entries[:3])}{', ...' if len(entries) > 3 else ''})")
        )
        return f"already holds {held}; pass a new {flag}, or add --force to replace it"
    nested = runs_below([target / n for n in entries])
    if nested:
        return f"holds run directories below it (e.g. {nested[0]}); replacing it would delete them, {never}"
    table = next((p for p in sorted(target.rglob("*.csv")) if verified_rows(p)), None)
    if table is not None:
        return f"holds {table}, a table with rows marked verified; replacing it would delete them, {never}"
    return None


class Output:
    """The one output helper of every command that writes where it is told: made before any work, it
    applies the rule (:func:`check_output`, same arguments); :meth:`writing` wraps the writing
    (``with out.writing() as path: atomic.write_text(path, text)``)."""

    def __init__(
        self,
        out: str | Path,
        kind: str = "file",
        inputs: Sequence[Input] = (),
        force: bool = False,
        flag: str = "--out",
        **rule,
    ) -> None:
        self.out, self.flag = out, flag
        self.path = check_output(out, kind, inputs, force, flag, **rule)
        self.new = not self.path.exists() or (self.path.is_dir() and not any(self.path.iterdir()))

    @contextlib.contextmanager
    def writing(self) -> Iterator[Path]:
        """A new target is claimed at the final move (:func:`catpose.atomic.claiming`: what another
        command wrote there meanwhile is kept, and this one fails in one line); an ``OSError``
        (a read-only folder, a full disk) is one line (:func:`write_error_text`)."""
        from catpose import atomic

        try:
            with atomic.claiming(*([self.path] if self.new else [])):
                yield self.path
        except atomic.Claimed as e:
            if absolute_path(e.filename) != self.path:  # another Output's target, in a block nested in this one
                raise
            raise InvalidInputError(
                f"{self.flag} {self.out} was written by another command while this one ran; it is kept: "
                f"pass another {self.flag}"
            ) from None
        except OSError as e:
            raise InvalidInputError(write_error_text(self.out, e, self.flag)) from None


def add_output_options(ap, help: str, required: bool = True, force_help: str = "replace an existing --out") -> None:
    """The ``--out`` and ``--force`` options of a command that writes (:class:`Output`)."""
    ap.add_argument("--out", required=required, default=None, help=help)
    ap.add_argument(
        "--force", action="store_true", help=f"{force_help} (never an input, a run being written or a verified table)"
    )


def oserror_reason(e: OSError) -> str:
    """What an ``OSError`` while writing means, in words: the disk is full, a folder is not writable, ..."""
    if e.errno in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT):
        return "the disk is full"
    if e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "the folder is not writable"
    if e.errno in (errno.ENOTDIR, errno.EEXIST) or isinstance(e, (NotADirectoryError, FileExistsError)):
        return "a file is in the way of a folder on its path"
    return e.strerror or type(e).__name__


def write_error_text(out: str | Path, e: OSError, flag: str = "--out") -> str:
    """One line for an ``OSError`` while writing ``out``: what happened and the fix."""
    return f"cannot write {flag} {out} ({oserror_reason(e)}: {e.strerror or e}); pass a writable folder with free space"


@contextlib.contextmanager
def output_errors(out: str | Path, flag: str = "--out") -> Iterator[None]:
    """Turn an ``OSError`` while writing ``out`` into one :class:`InvalidInputError` line
    (:func:`write_error_text`); what was written is left whole or not at all (:mod:`catpose.atomic`)."""
    try:
        yield
    except OSError as e:
        raise InvalidInputError(write_error_text(out, e, flag)) from None
