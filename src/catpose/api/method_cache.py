"""Methods for :func:`catpose.register`, built from ``configs/method/<name>.yaml`` by the same builder
as ``bench run`` (:func:`catpose.bench.run.build.build_from_config`), keyword options as overrides."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from catpose.errors import CatposeError, InvalidInputError
from catpose.lru import LRUCache

__all__ = ["build_method", "prepare_template", "uses_up"]

#: Methods built from configs, reused across calls (their template caches with them).
_METHODS: LRUCache[tuple, Any] = LRUCache(4)


def _override_value(value: Any) -> str:
    """A Python value as Hydra override syntax (``None`` -> ``null``, strings quoted)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(float(value)) if isinstance(value, (float, np.floating)) else str(int(value))
    if isinstance(value, str):
        return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_override_value(v) for v in value) + "]"
    raise InvalidInputError(
        f"option value {value!r} ({type(value).__name__}) is not a number, string, bool, None or list"
    )


def _overrides(options: Mapping[str, Any], prefix: str = "method") -> list[str]:
    """``{"selection": {"gravity_max_deg": None}, "descriptor": "pfh"}`` -> Hydra overrides:
    nested dicts become dotted keys; a string naming a config of the group ``configs/<key>/``
    (``descriptor="pfh"``) selects that config, as ``descriptor@method.descriptor=pfh`` does."""
    from importlib import resources

    out = []
    for key, value in options.items():
        if isinstance(value, Mapping):
            out += _overrides(value, f"{prefix}.{key}")
            continue
        group = resources.files("catpose.configs") / str(key)
        if prefix == "method" and isinstance(value, str) and (group / f"{value}.yaml").is_file():
            out.append(f"{key}@method.{key}={value}")
        else:
            out.append(f"{prefix}.{key}={_override_value(value)}")
    return out


def _check_keys(name: str, node: Any, options: Mapping[str, Any], path: str = "") -> None:
    """Refuse an option that ``configs/method/<name>.yaml`` does not have, in the API's words
    (keyword arguments, not Hydra's ``+method.x`` overrides), listing the options that exist."""
    from omegaconf import DictConfig

    for key, value in options.items():
        dotted = f"{path}{key}"
        known = sorted(k for k in node if k not in ("_target_", "name")) if isinstance(node, DictConfig) else []
        if not isinstance(node, DictConfig) or key not in node:
            where = f"{path[:-1]} " if path else ""
            raise InvalidInputError(
                f"{dotted} is not an option of method {name!r}; its {where}options are: {', '.join(known)} "
                f"(configs/method/{name}.yaml)"
            )
        child = node[key]
        if isinstance(value, Mapping):
            if not isinstance(child, DictConfig):
                raise InvalidInputError(
                    f"option {dotted} of method {name!r} is a value, not a group: pass {key}=<value>"
                )
            _check_keys(name, child, value, f"{dotted}.")


def build_method(name: str, **options: Any) -> Any:
    """The method ``configs/method/<name>.yaml`` with ``options`` as overrides, built by the same
    builder as ``bench run`` (cached: the same name and options give the same object, whose
    template caches then serve later calls). A one-line :class:`InvalidInputError` names an
    unknown method or option."""
    key = (name, repr(sorted(options.items())))
    hit = _METHODS.get(key)
    if hit is not None:
        return hit
    from catpose.bench.run.build import build_from_config
    from catpose.bench.run.config import available, compose

    names = available("method")
    if name not in names:
        raise InvalidInputError(
            f"method={name!r} is not a method config; choose one of {', '.join(names)} "
            "or pass a RegistrationMethod instance"
        )
    if options:
        _check_keys(name, compose([f"method={name}"]).method, options)
    try:
        cfg = compose([f"method={name}", *_overrides(options)], hint="see configs/method/" + name + ".yaml")
    except CatposeError as e:
        raise InvalidInputError(f"options {sorted(options)} do not fit method {name!r}: {e}") from None
    try:
        built = build_from_config(cfg.method, "method")[1]
    except CatposeError as e:
        raise InvalidInputError(f"options of method {name!r}: {e}") from None
    _METHODS.put(key, built)
    return built


def uses_up(method: Any) -> bool:
    """Whether the method reads the ground normal: ours (descriptor frames and gravity filter),
    a correspondence baseline on LPS features; not ICP, FPFH or PFH matching."""
    from catpose.methods.ours import Ours

    if isinstance(method, Ours):
        return True
    return getattr(method, "features", None) == "lps"


def prepare_template(method: Any, template: Any) -> None:
    """Build ``method``'s per-template data for ``template`` (object-normalised) now instead of on
    the first registration. Ours: the partial-view dictionary and descriptors of the template and
    of each of its gravity hypotheses (:mod:`catpose.methods.ours.resting`), loaded from the
    disk cache when there, and the depth check's ray caster of its mesh. Other methods build
    theirs on their first call (FPFH features take milliseconds; the dictionary baselines share
    ours' disk-cached dictionary features)."""
    from catpose.methods.ours import Ours

    if isinstance(method, Ours):
        method.prepare_template(template)
