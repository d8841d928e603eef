"""Hydra's own command-line flags on ``bench run``'s command line (Hydra 1.3:
``hydra/_internal/utils.py`` ``get_args_parser``), told apart from the plain overrides that
:mod:`catpose.bench.run.config` checks: which take a value, which are modes (one per command
line) and which make Hydra read other configs than the package's."""

from __future__ import annotations

from collections.abc import Sequence

from catpose.errors import ConfigError

#: flags that take a value (``--cfg job`` or ``--cfg=job``), long and short spellings
HYDRA_VALUE_FLAGS = {
    "--cfg": "--cfg",
    "-c": "--cfg",
    "--package": "--package",
    "-p": "--package",
    "--config-path": "--config-path",
    "-cp": "--config-path",
    "--config-name": "--config-name",
    "-cn": "--config-name",
    "--config-dir": "--config-dir",
    "-cd": "--config-dir",
    "--experimental-rerun": "--experimental-rerun",
}
#: ``--info`` takes an optional value, one of these (default ``all``)
HYDRA_INFO_CHOICES = ("all", "config", "defaults", "defaults-tree", "plugins", "searchpath")
#: flags without a value
HYDRA_SWITCHES = {
    "--resolve": "--resolve",
    "--run": "--run",
    "-r": "--run",
    "--multirun": "--multirun",
    "-m": "--multirun",
    "--shell-completion": "--shell-completion",
    "-sc": "--shell-completion",
    "--hydra-help": "--hydra-help",
    "--version": "--version",
    "--info": "--info",
    "-i": "--info",
}
#: flags that make Hydra read other configs than the package's (names and composition unchecked)
OTHER_CONFIGS = ("--config-path", "--config-name", "--config-dir", "--experimental-rerun")


def split_hydra_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """``(flags, overrides)``: Hydra's command-line flags with their values, as typed (``--cfg``,
    ``job``, ``--info``, ``plugins``, ``--config-dir=DIR``, ...), and the plain overrides
    (``key=value``, ``+key=value``, ``~key``). The flags go to Hydra untouched; only the
    overrides are checked here. A flag Hydra does not know is left among the overrides, where
    Hydra reports it."""
    flags: list[str] = []
    overrides: list[str] = []
    args = list(argv)
    k = 0
    while k < len(args):
        a = args[k]
        name, eq, _ = a.partition("=")
        if a.startswith("-") and name in HYDRA_VALUE_FLAGS:
            flags.append(a)
            if not eq and k + 1 < len(args):
                flags.append(args[k + 1])
                k += 1
        elif a.startswith("-") and name in ("--info", "-i"):
            flags.append(a)
            if not eq and k + 1 < len(args) and args[k + 1] in HYDRA_INFO_CHOICES:
                flags.append(args[k + 1])
                k += 1
        elif a.startswith("-") and a in HYDRA_SWITCHES:
            flags.append(a)
        else:
            overrides.append(a)
        k += 1
    return flags, overrides


def flag_names(flags: Sequence[str]) -> set[str]:
    """The long names of the Hydra flags among ``flags`` (values dropped): ``{"--cfg", ...}``."""
    out = set()
    for f in flags:
        name = f.partition("=")[0]
        if f.startswith("-") and (name in HYDRA_VALUE_FLAGS or name in HYDRA_SWITCHES):
            out.add(HYDRA_VALUE_FLAGS.get(name) or HYDRA_SWITCHES[name])
    return out


#: Hydra's modes: one per command line (Hydra refuses two, with a traceback)
HYDRA_MODES = {
    "--multirun": "-m",
    "--run": "--run",
    "--cfg": "--cfg",
    "--info": "--info",
    "--shell-completion": "--shell-completion",
}


def check_modes(flags: Sequence[str]) -> None:
    """Fail fast, in one line, on two of Hydra's modes together (``-m`` with ``--cfg job``);
    ``flags`` as :func:`split_hydra_args` returns them."""
    names = flag_names(flags)
    modes = [shown for name, shown in HYDRA_MODES.items() if name in names]
    if len(modes) > 1:
        hint = (
            " (show one job's config: drop -m and give one value per key, e.g. bench run method=icp --cfg job)"
            if "-m" in modes and "--cfg" in modes
            else ""
        )
        raise ConfigError(
            f"{' and '.join(modes)} cannot be combined: pass one of -m, --run, --cfg, --info, --shell-completion{hint}"
        )
