"""Logging: every catpose module logs through ``logging.getLogger(__name__)`` below the ``catpose``
logger; nothing in the library prints diagnostics, and used as a library catpose adds no handler.

The command line calls :func:`configure` once: one line per record on stderr, prefixed with the
command (``bench run: warning: ...``; INFO without a level word; a tqdm bar is kept intact).
:func:`configure_run` sets a ``bench run`` job's level from ``log_level`` or Hydra's
``hydra.verbose``, and hands the records to Hydra's handlers under a Hydra job logging config.
A command's results (tables, written file names) are stdout, not logging.
"""

from __future__ import annotations

import logging
import sys
from typing import Any

from catpose.errors import ConfigError

ROOT = "catpose"
LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")


class _LineFormatter(logging.Formatter):
    """``<prefix>: [<level>: ][[<logger>] ]<message>`` (the logger's name at DEBUG only)."""

    def __init__(self, prefix: str) -> None:
        super().__init__()
        self.prefix = prefix

    def format(self, record: logging.LogRecord) -> str:
        text = record.getMessage()
        if record.exc_info and record.levelno <= logging.DEBUG:
            text += "\n" + self.formatException(record.exc_info)
        if record.levelno == logging.INFO:
            return f"{self.prefix}: {text}"
        if record.levelno <= logging.DEBUG:
            return f"{self.prefix}: debug: [{record.name}] {text}"
        return f"{self.prefix}: {record.levelname.lower()}: {text}"


class _StderrHandler(logging.Handler):
    """Writes to the ``sys.stderr`` of the moment (tests capture it) and through ``tqdm.write``
    while a progress bar is shown, so the bar is redrawn below the line instead of broken."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            line = self.format(record)
            tqdm_module = sys.modules.get("tqdm")
            bars = getattr(getattr(tqdm_module, "tqdm", None), "_instances", None)
            if bars:
                tqdm_module.tqdm.write(line, file=sys.stderr)
            else:
                sys.stderr.write(line + "\n")
                sys.stderr.flush()
        except Exception:  # noqa: BLE001 - logging must never break the program (logging's own rule)
            self.handleError(record)


def level_of(value: Any, key: str = "log_level") -> int:
    """A level name (any case) or number as ``logging``'s number; a :class:`ConfigError` naming
    ``key`` and the choices otherwise."""
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    name = str(value).strip().upper()
    if name not in LEVELS:
        raise ConfigError(f"{key}={value} is not a log level; use one of {', '.join(LEVELS)} (e.g. {key}=WARNING)")
    return int(getattr(logging, name))


def configure(command: str, level: Any = "INFO", prefix: str | None = None) -> logging.Logger:
    """Send the ``catpose`` logger's records to stderr as one line each, prefixed ``bench
    <command>`` (or ``prefix``), replacing a handler an earlier call added, at ``level``.
    Returns the logger."""
    logger = logging.getLogger(ROOT)
    for h in [h for h in logger.handlers if isinstance(h, _StderrHandler)]:
        logger.removeHandler(h)
    handler = _StderrHandler()
    handler.setFormatter(_LineFormatter(prefix if prefix is not None else f"bench {command}".strip()))
    logger.addHandler(handler)
    logger.propagate = False  # one line per record, even when the application configures the root logger
    logger.setLevel(level_of(level))
    return logger


def _verbose_names(verbose: Any) -> list[str] | bool:
    """Hydra's ``hydra.verbose``: ``True``/``False`` or the logger names it lists."""
    if isinstance(verbose, bool) or verbose is None:
        return bool(verbose)
    if isinstance(verbose, str):
        return [verbose]
    return [str(v) for v in verbose]


def configure_run(log_level: Any = "INFO", verbose: Any = False, hydra_logging: bool = False) -> int:
    """The levels of a ``bench run`` job: ``log_level`` (the config key) for the ``catpose``
    logger, DEBUG when ``verbose`` (Hydra's ``hydra.verbose``) is true or names ``catpose``.
    Hydra has already set the loggers ``verbose`` names (e.g. one module's) to DEBUG; those keep
    it. Adds the stderr handler when the job runs in a process the CLI did not start (a
    launcher's worker). ``hydra_logging``: the user chose a Hydra job logging config with a root
    logger (``hydra/job_logging=default``, which also writes the job's ``.log`` file); catpose's
    records then go there instead (no handler of ours, propagated to the root logger). Returns
    the ``catpose`` logger's level."""
    level = level_of(log_level)
    logger = logging.getLogger(ROOT)
    ours = [h for h in logger.handlers if isinstance(h, _StderrHandler)]
    if hydra_logging:
        for h in ours:
            logger.removeHandler(h)
        logger.propagate = True
    elif not ours:
        configure("run", level)
    names = _verbose_names(verbose)
    if names is True or (isinstance(names, list) and ROOT in names):
        level = logging.DEBUG
    logger.setLevel(level)
    return level
