"""Errors that reach the user as one line.

Every error a user can cause (a bad path, a malformed file, a degenerate cloud, an unknown
name) is raised as a :class:`CatposeError` whose message names the problem and the fix. The CLI
prints it as one line and exits with status 2; inside a run the sample is recorded as failed
with that message.
"""


class CatposeError(Exception):
    """Base class: a problem the user can fix; the message says how."""


class InvalidInputError(CatposeError, ValueError):
    """A point cloud, pose or array that no method can work with (empty, NaN, degenerate)."""


class DatasetError(CatposeError):
    """A missing or malformed dataset root, file or sample."""


class ConfigError(CatposeError):
    """An unknown name or a wrong option in the configuration."""


class RunAborted(CatposeError):
    """The run itself cannot go on (not one sample's fault): a broken installation, no memory,
    an unwritable output directory, a run directory held by another run. Nothing is recorded for
    the sample in progress, so a re-run redoes it."""


def one_line(e: BaseException) -> str:
    """An exception as one line: a catpose error's own message, or ``Type: message (at file:line)``."""
    import traceback
    from pathlib import Path

    msg = " ".join(str(e).split()) or "(no message)"
    if isinstance(e, CatposeError):
        return msg
    tb = traceback.extract_tb(e.__traceback__)
    where = f" (at {Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
    return f"{type(e).__name__}: {msg}{where}"


def command_error(command: str, error: BaseException | str) -> str:
    """The one line every ``bench`` command prints for a user error (exit status 2):
    ``bench <command>: error: <message>``. The CLI prints it for every command
    (:func:`catpose.bench.cli.main`); a command that must print it itself (inside Hydra's job,
    or run as ``python -m``) uses this too, so every error reads the same."""
    return f"bench {command}: error: {error}"


class RegistrationFailed(CatposeError):
    """A method gave no pose for an input that passed every check (e.g. TEASER found no
    consistent correspondences): the method failed, not the input (``catpose.register``)."""
