"""Hydra, composed in one place: the ``run`` config with command-line overrides, checked first.

Every command that needs a config composes it through :func:`compose` (or
:func:`compose_and_build`, which also builds groups with
:func:`catpose.bench.run.build.build_from_config`); ``bench run`` then goes through ``hydra.main``
(:mod:`catpose.bench.run.command`). What a user types is checked before Hydra sees it: an unknown
group name, key or launcher is one line naming the closest valid ones (``difflib``), or the
config of its group that has the key; a sweep's group combinations are checked before its first
job (:func:`check_sweep_composition`). Hydra's own flags (``--cfg``, ``--info``, ``-m``, read off
Hydra 1.3's argument parser, ``hydra/_internal/utils.py``) are told apart from the plain overrides
(:func:`split_hydra_args`) and passed to Hydra untouched. Also here: the shared real data
(:func:`shared_data_dir`)."""

from __future__ import annotations

import difflib
import os
import re
from collections.abc import Iterable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from catpose.errors import ConfigError

REPO = Path(__file__).resolve().parents[2]

#: config groups whose names a command line picks (``method=ours``); their names are checked
GROUPS = ("method", "dataset", "protocol", "choice", "experiment")
#: hydra/launcher option -> the plugin package it needs (the cluster extra, `make cluster`)
LAUNCHER_PLUGINS = {
    "joblib": "hydra_joblib_launcher",
    "local_procs": "hydra_joblib_launcher",
    "submitit_local": "hydra_submitit_launcher",
    "submitit_slurm": "hydra_submitit_launcher",
    "slurm": "hydra_submitit_launcher",
    "ray": "hydra_ray_launcher",
    "ray_local": "hydra_ray_launcher",
}
#: what a composition error suggests by default
HINT = "bench run --help lists the common keys"


def shared_data_dir() -> Path:
    """``$CATPOSE_SHARED_DATA`` or ``../shared/data`` beside the checkout (the real data)."""
    env = os.environ.get("CATPOSE_SHARED_DATA")
    return Path(env) if env else REPO.parent / "shared" / "data"


def available(group: str) -> list[str]:
    """Config names of a group (``configs/<group>/*.yaml``), read from the installed package."""
    root = resources.files("catpose.configs") / group
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".yaml"))


def did_you_mean(word: str, candidates: Iterable[str], spell=lambda c: c) -> str:
    """``did you mean `a` or `b`?`` for the candidates closest to ``word`` (difflib), each
    written by ``spell``; empty when none is close."""
    close = difflib.get_close_matches(word, sorted(set(candidates)), n=3, cutoff=0.6)
    return f"did you mean {' or '.join(f'`{spell(c)}`' for c in close)}?" if close else ""


def check_overrides(argv: Sequence[str], names: bool = True) -> None:
    """Fail fast, in one line, on an unknown method, dataset, protocol or experiment name.

    ``argv`` are plain overrides (:func:`split_hydra_args` takes Hydra's flags out first);
    ``hydra.*`` and ``hydra/...`` overrides are Hydra's and pass untouched. ``names=False`` skips
    the name check (configs from ``--config-dir`` are not in the package's lists)."""
    for arg in argv:
        raw, sep, value = arg.partition("=")
        key = raw.lstrip("+~")
        prefix = raw[: len(raw) - len(key)]  # "+" / "~" as typed
        if key == "hydra" or key.startswith(("hydra.", "hydra/")):
            continue
        if not sep or key not in GROUPS:
            continue
        available_names = available(key)
        for v in value.split(","):
            if names and v and v not in available_names:
                guess = did_you_mean(v, available_names, lambda c: f"{prefix}{key}={c}")
                raise ConfigError(
                    f"unknown {key} {v!r}; {guess + ' ' if guess else ''}available: {', '.join(available_names)} "
                    f"(add configs/{key}/{v}.yaml to plug in a new one)"
                )


def check_launcher(argv: Sequence[str]) -> None:
    """Fail fast, in one line, on a launcher whose Hydra plugin is not installed."""
    import importlib.util

    for arg in argv:
        key, sep, value = arg.partition("=")
        if key.lstrip("+~") != "hydra/launcher" or not sep or value == "basic":
            continue
        plugin = LAUNCHER_PLUGINS.get(value)
        if plugin is None:
            raise ConfigError(f"unknown hydra/launcher {value!r}; use one of basic, {', '.join(LAUNCHER_PLUGINS)}")
        try:
            found = importlib.util.find_spec(f"hydra_plugins.{plugin}") is not None
        except ImportError:
            found = False
        if not found:
            raise ConfigError(
                f"hydra/launcher={value} needs {plugin.replace('_', '-')}, which is not installed; "
                f'install the launchers with `make cluster` (pip install -e ".[cluster]")'
            )


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


def compose(overrides: Sequence[str], hint: str = HINT) -> Any:
    """The ``run`` config (``configs/run.yaml``) composed with ``overrides`` (Hydra's compose API).

    The overrides are checked first (:func:`check_overrides`). Raises :class:`ConfigError` in one
    line, ending with ``hint``, for an override that does not fit the config (a key that does
    not exist, such as a misspelt ``datset=...`` or ``method.foo=1`` without ``+``; broken
    override syntax).
    """
    overrides = list(overrides)
    check_overrides(overrides)
    from hydra.errors import ConfigCompositionException, OverrideParseException

    try:
        cfg = _compose(overrides)
    except (ConfigCompositionException, OverrideParseException) as e:
        bad = re.match(r"Could not override '([^']+)'", str(e))
        if bad:
            raise ConfigError(unknown_key_message(overrides, bad.group(1), hint)) from None
        for o in overrides if "LexerNoViableAlt" in str(e) else ():
            key, _, value = o.partition("=")
            if o.startswith("-"):
                raise ConfigError(f"unknown option {o} ({hint})") from None
            if not value.isascii() or " " in value:
                raise ConfigError(
                    f"{o}: quote a value with spaces or non-ASCII letters for Hydra, and the quotes for the shell: "
                    f"\"{key}='{value}'\""
                ) from None
        parts = [str(e)] + ([str(e.__cause__).splitlines()[0]] if e.__cause__ is not None else [])
        lines = [
            ln.strip().rstrip(".")
            for p in parts
            for ln in p.splitlines()
            if ln.strip() and not ln.startswith(("See https://", "Set the environment"))
        ]
        raise ConfigError("; ".join(lines) + f" ({hint})") from None
    for key in ("retry_failed", "progress", "print_summary"):
        if not isinstance(cfg.get(key, False), bool):
            raise ConfigError(f"{key}={cfg.get(key)!r}: pass true or false")
    return cfg


def _compose(overrides: Sequence[str]) -> Any:
    """Hydra's compose API on the package's ``run`` config (errors as Hydra raises them)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_module

    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        return hydra_compose(config_name="run", overrides=list(overrides))


def _override_key(override: str) -> str:
    return override.partition("=")[0].lstrip("+~")


def unknown_key_message(overrides: Sequence[str], key: str, hint: str = HINT) -> str:
    """One line for an override of a key the composed config does not have: the closest keys at
    the level where the path stops (``metod`` -> `method=...`), or, for a key of a config group
    (``method.optimiser.lr`` under ``method=icp``), the group's configs that have it."""
    from omegaconf import DictConfig, OmegaConf

    typed = next((o for o in overrides if _override_key(o) == key), key)
    value = typed.partition("=")[2]
    others = [o for o in overrides if _override_key(o) != key]
    head = f"unknown key '{key}' ({typed})"
    tail = f"(+{key}={value} adds a new key; {hint})" if value else f"({hint})"
    try:
        cfg = _compose(others)
    except Exception:  # noqa: BLE001 - the other overrides are broken too: no suggestion, Hydra's words
        return f"{head} {tail}"
    parts = key.split(".")
    node, depth = cfg, 0
    while depth < len(parts) and isinstance(node, DictConfig) and parts[depth] in node:
        node, depth = node[parts[depth]], depth + 1
    if not isinstance(node, DictConfig):  # a value, not a node: nothing below it
        return f"{head}: {'.'.join(parts[:depth])} is a value, not a group of keys ({hint})"
    if depth == len(parts):  # the key is a group of keys, and the mapping given names keys it lacks
        keys = ", ".join(sorted(str(k) for k in node.keys())) or "no keys"
        return f"{typed}: {key} has {keys}; a new key in it needs ++ (`++{key}={value}` merges the mapping in)"
    rest = ".".join(parts[depth + 1 :])
    guess = did_you_mean(
        parts[depth],
        [str(k) for k in node.keys()],
        lambda c: ".".join([*parts[:depth], c] + ([rest] if rest else [])) + (f"={value}" if value else ""),
    )
    if guess:
        return f"{head}; {guess} {tail}"
    group = parts[0] if parts[0] in GROUPS[:3] and depth >= 1 else None
    if group:  # another config of the group has the key: name it
        current = str(cfg[group].get("name", ""))
        having, absent = [], object()
        for name in available(group):
            if name == current:
                continue
            try:
                there = _compose([o for o in others if _override_key(o) != group] + [f"{group}={name}"])
                if OmegaConf.select(there, key, default=absent, throw_on_resolution_failure=False) is not absent:
                    having.append(name)
            except Exception:  # noqa: BLE001 - a config that needs other settings (a dataset root) proves nothing
                continue
        if having:
            has = f"{group} {', '.join(having)} {'has' if len(having) == 1 else 'have'} it"
            return (
                f"{head}: {group} {current} has no {'.'.join(parts[: depth + 1])}; {has}: `{group}={having[0]} {typed}`"
            )
    where = ".".join(parts[:depth]) or "the run config"
    keys = sorted(str(k) for k in node.keys() if not str(k).startswith("_"))
    shown = ", ".join(keys[:10]) + (f" and {len(keys) - 10} more" if len(keys) > 10 else "")
    add = f"; +{key}={value} adds a new key" if value else ""
    return f"{head}: {where} has {shown} (bench run --cfg job shows them{add})"


#: at most this many group combinations of a sweep are composed before it starts
SWEEP_CHECK_LIMIT = 24


def check_sweep_composition(overrides: Sequence[str]) -> None:
    """``bench run -m``'s fail-fast check: every combination of the swept method, dataset and
    protocol names (the other keys at their first value) composes, or the one-line error of
    :func:`compose`, naming the job's choices. Sweeps that compose their own rows (``+experiment``,
    ``+row``) or that set Hydra keys are left to Hydra, as are more than
    :data:`SWEEP_CHECK_LIMIT` combinations."""
    import itertools

    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    plain = [o for o in overrides if not _override_key(o).startswith("hydra")]
    if any(_override_key(o) in ("experiment", "row") for o in plain):
        return
    try:
        parsed = OverridesParser.create().parse_overrides(plain)
    except HydraException as e:
        raise ConfigError(f"{' '.join(str(e).split())} ({HINT})") from None
    choices: list[list[str]] = []
    for o in parsed:
        element = o.get_key_element()
        if o.is_sweep_override():
            try:
                values = [str(v) for v in o.sweep_string_iterator()]
            except Exception:  # noqa: BLE001 - an interval or a sweep Hydra expands itself: its first job tells
                return
            values = values if o.key_or_group in GROUPS[:3] else values[:1]
            choices.append([f"{element}={v}" for v in values])
        else:
            choices.append([element if o.value_type is None else f"{element}={o.get_value_element_as_str()}"])
    combos = list(itertools.islice(itertools.product(*choices), SWEEP_CHECK_LIMIT + 1))
    if len(combos) > SWEEP_CHECK_LIMIT:
        return
    for combo in combos:
        try:
            compose(combo)
        except ConfigError as e:
            groups = [c for c in combo if _override_key(c) in GROUPS[:3]]
            raise ConfigError(f"in the sweep's job {' '.join(groups) or '(defaults)'}: {e}") from None


def compose_and_build(
    overrides: Sequence[str], groups: Sequence[str], hint: str = HINT
) -> tuple[Any, list[tuple[str, Any]]]:
    """:func:`compose`, then each of ``groups`` (``"method"``, ``"dataset"``, ``"protocol"``)
    built as ``bench run`` builds it: ``(cfg, [(name, object) per group])``; a dataset also gets
    its config name as ``.name``. Every mistake is a one-line :class:`ConfigError` naming the key."""
    from catpose.bench.run.build import build_from_config

    cfg = compose(overrides, hint)
    built = [build_from_config(cfg[group], group) for group in groups]
    for (name, obj), group in zip(built, groups):
        if group == "dataset":
            obj.name = name
    return cfg, built


def check_run_args(argv: Sequence[str]) -> None:
    """Every check ``bench run`` makes before Hydra, on the plain overrides only: names
    (:func:`check_overrides`), the launcher's plugin (:func:`check_launcher`) and the composition:
    a single run's composes once (:func:`compose`), a sweep's every group combination
    (:func:`check_sweep_composition`). A command line that points Hydra at other configs
    (``--config-dir``, ``--config-name``, ``--config-path``) is left to Hydra, as is a single run
    that sets Hydra keys or an experiment."""
    flags, overrides = split_hydra_args(argv)
    check_modes(flags)
    names = flag_names(flags)
    other_configs = bool(names & set(OTHER_CONFIGS))
    check_overrides(overrides, names=not other_configs)
    check_launcher(overrides)
    if other_configs:
        return
    if "--multirun" in names:
        check_sweep_composition(overrides)
    elif not any(a.lstrip("+~").startswith(("hydra", "experiment")) for a in overrides):
        compose(overrides)
