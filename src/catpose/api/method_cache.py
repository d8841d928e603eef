"""Methods for :func:`catpose.register`, built without Hydra: ``configs/method/<name>.yaml`` read
with PyYAML, its defaults list resolved from ``configs/<group>/<name>.yaml`` as Hydra composes it,
the keyword options merged in, and every ``_target_`` built with plain arguments (children first,
as Hydra's ``instantiate``). The constructors check their arguments (one line naming the option);
the method registry (:mod:`catpose.methods.registry`) says which methods there are.
``tests/test_api_bench_agreement.py`` checks that this gives ``bench run``'s method, pose for pose."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from importlib import resources
from typing import Any

from catpose.errors import CatposeError, InvalidInputError, one_line
from catpose.lru import LRUCache

__all__ = ["build_method", "read_config"]

#: Methods built from configs, reused across calls (their template caches with them).
_METHODS: LRUCache[tuple, Any] = LRUCache(4)


def _read(group: str, name: str) -> dict:
    import yaml

    path = resources.files("catpose.configs") / group / f"{name}.yaml"
    if not path.is_file():
        raise InvalidInputError(f"configs/{group}/{name}.yaml does not exist")
    return yaml.safe_load(path.read_text()) or {}


def _merge(base: dict, top: Mapping) -> dict:
    """``top`` over ``base``, nested groups merged key by key."""
    out = dict(base)
    for key, value in top.items():
        out[key] = _merge(out[key], value) if isinstance(value, Mapping) and isinstance(out.get(key), dict) else value
    return out


def _resolve(node: Any, run: Mapping) -> Any:
    """``${seed}``-style values (a key of ``configs/run.yaml``) replaced by that key's default."""
    if isinstance(node, dict):
        return {k: _resolve(v, run) for k, v in node.items()}
    if isinstance(node, str) and node.startswith("${") and node.endswith("}") and node[2:-1] in run:
        return run[node[2:-1]]
    return node


def read_config(group: str, name: str) -> dict:
    """``configs/<group>/<name>.yaml`` as a plain dict, its defaults list resolved: ``_self_``
    (last when not listed) over entries ``other`` (the same group, merged here),
    ``/group/name@_here_`` (merged here) and ``/group@key: name`` (under ``key``)."""
    raw = _read(group, name)
    entries = raw.pop("defaults", [])
    out: dict = {}
    for entry in entries if "_self_" in entries else [*entries, "_self_"]:
        if entry == "_self_":
            out = _merge(out, raw)
            continue
        path, choice = next(iter(entry.items())) if isinstance(entry, dict) else (entry, None)
        path, _, package = path.partition("@")
        if choice is None:
            path, _, choice = path.rpartition("/")
        node = read_config(path.lstrip("/") if path.startswith("/") else group, choice)
        out = _merge(out, node if package in ("", "_here_") else {package: node})
    return out


def _with_options(name: str, node: dict, options: Mapping[str, Any], path: str = "") -> dict:
    """``node`` with ``options`` merged in; an option the config does not have is refused in the
    API's words (keyword arguments, not Hydra's overrides), listing the options that exist. A dict
    for a group (an object's options, ``selection={"rule": "chamfer"}``) sets those of its keys, a
    string naming a config of the group ``configs/<key>/`` (``descriptor="pfh"``) selects it."""
    node = dict(node)
    for key, value in options.items():
        dotted = f"{path}{key}"
        if key not in node or key in ("_target_", "name"):
            known = sorted(k for k in node if k not in ("_target_", "name"))
            where = f"{path[:-1]} " if path else ""
            raise InvalidInputError(
                f"{dotted} is not an option of method {name!r}; its {where}options are: {', '.join(known)} "
                f"(configs/method/{name}.yaml)"
            )
        child = node[key]
        is_group = isinstance(child, dict) and "_target_" in child  # an object's options; other dicts are values
        if isinstance(value, Mapping) and is_group:
            node[key] = _with_options(name, child, value, f"{dotted}.")
        elif is_group and isinstance(value, str):
            if not (resources.files("catpose.configs") / key / f"{value}.yaml").is_file():
                raise InvalidInputError(
                    f"{dotted}={value!r} of method {name!r}: configs/{key}/{value}.yaml does not exist"
                )
            node[key] = read_config(key, value)
        else:
            node[key] = value
    return node


def _instantiate(node: Any) -> Any:
    """Every ``_target_`` of ``node`` built with its other keys, children first."""
    if isinstance(node, list):
        return [_instantiate(v) for v in node]
    if not isinstance(node, dict):
        return node
    args = {k: _instantiate(v) for k, v in node.items() if k != "_target_"}
    if "_target_" not in node:
        return args
    module, _, attr = str(node["_target_"]).rpartition(".")
    return getattr(importlib.import_module(module), attr)(**args)


def build_method(name: str, **options: Any) -> Any:
    """The method ``configs/method/<name>.yaml`` with ``options`` (keyword arguments; a nested group
    as a dict: ``selection={"rule": "chamfer"}``), as ``bench run method=<name>`` builds it (cached:
    the same name and options give the same object, whose template caches then serve later calls).
    A one-line :class:`InvalidInputError` names an unknown method or option."""
    key = (name, repr(sorted(options.items())))
    hit = _METHODS.get(key)
    if hit is not None:
        return hit
    from catpose.methods.registry import registered

    names = list(registered())
    if name not in names:
        raise InvalidInputError(
            f"method={name!r} is not a method config; choose one of {', '.join(names)} "
            "or pass a RegistrationMethod instance"
        )
    node = _with_options(name, read_config("method", name), options)
    node.pop("name", None)
    try:
        built = _instantiate(_resolve(node, _read("", "run")))
    except CatposeError as e:
        raise InvalidInputError(f"options of method {name!r}: {e}") from None
    except (TypeError, ValueError) as e:
        raise InvalidInputError(f"options {sorted(options)} of method {name!r}: {one_line(e)}") from None
    _METHODS.put(key, built)
    return built
