"""Hydra's own command-line flags on ``bench run``'s command line (Hydra 1.3:
``hydra/_internal/utils.py`` ``get_args_parser``), told apart from the plain overrides that
:mod:`catpose.bench.run.config` checks: which take a value, which are modes (one per command
line) and which make Hydra read other configs than the package's."""

from __future__ import annotations

from collections.abc import Sequence

from catpose.errors import ConfigError


def _options() -> dict[str, tuple[str, object, object]]:
    """Hydra's flags from its own argument parser: option string (``-c``, ``--cfg``) -> (long name,
    ``nargs``: None a value, ``"?"`` an optional one of ``choices``, 0 none, ``choices``)."""
    from hydra._internal.utils import get_args_parser

    out = {}
    for action in get_args_parser()._actions:
        if action.option_strings and action.dest != "help":
            long = max(action.option_strings, key=len)
            out.update({s: (long, action.nargs, action.choices) for s in action.option_strings})
    return out


#: flags that make Hydra read other configs than the package's (names and composition unchecked)
OTHER_CONFIGS = ("--config-path", "--config-name", "--config-dir", "--experimental-rerun")


def split_hydra_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """``(flags, overrides)``: Hydra's command-line flags with their values, as typed (``--cfg``,
    ``job``, ``--info``, ``plugins``, ``--config-dir=DIR``, ...), and the plain overrides
    (``key=value``, ``+key=value``, ``~key``). The flags go to Hydra untouched; only the
    overrides are checked here. A flag Hydra does not know is left among the overrides, where
    Hydra reports it."""
    options = _options()
    flags: list[str] = []
    overrides: list[str] = []
    args = list(argv)
    k = 0
    while k < len(args):
        a = args[k]
        name, eq, _ = a.partition("=")
        _, nargs, choices = options.get(name, (None, -1, None)) if a.startswith("-") else (None, -1, None)
        if nargs == -1 or (nargs == 0 and eq):
            overrides.append(a)
        else:
            flags.append(a)
            takes = nargs is None or (nargs == "?" and k + 1 < len(args) and args[k + 1] in (choices or ()))
            if not eq and takes and k + 1 < len(args):
                flags.append(args[k + 1])
                k += 1
        k += 1
    return flags, overrides


def flag_names(flags: Sequence[str]) -> set[str]:
    """The long names of the Hydra flags among ``flags`` (values dropped): ``{"--cfg", ...}``."""
    options = _options()
    return {options[f.partition("=")[0]][0] for f in flags if f.partition("=")[0] in options}


#: Hydra's modes: one per command line (Hydra refuses two, with a traceback)
HYDRA_MODES = ("--multirun", "--run", "--cfg", "--info", "--shell-completion")


def check_modes(flags: Sequence[str]) -> None:
    """Fail fast, in one line, on two of Hydra's modes together (``-m`` with ``--cfg job``);
    ``flags`` as :func:`split_hydra_args` returns them."""
    names = flag_names(flags)
    modes = ["-m" if name == "--multirun" else name for name in HYDRA_MODES if name in names]
    if len(modes) > 1:
        hint = ""
        if "-m" in modes and "--cfg" in modes:
            hint = " (show one job's config: drop -m and give one value per key, e.g. bench run method=icp --cfg job)"
        raise ConfigError(
            f"{' and '.join(modes)} cannot be combined: pass one of -m, --run, --cfg, --info, --shell-completion{hint}"
        )
