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
