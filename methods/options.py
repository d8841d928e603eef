"""One-line validation of method options at construction, naming the config key.

Each check raises :class:`~catpose.errors.ConfigError` such as
``method.optimiser.lr='abc' must be a positive number`` and returns the value converted to its
type, so constructors read ``self.lr = positive("method.optimiser.lr", lr)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from catpose.errors import ConfigError


def is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def positive(key: str, value: Any, integer: bool = False) -> Any:
    """``value`` > 0 as float (or int with ``integer``)."""
    kind = "integer" if integer else "number"
    if not is_number(value) or (integer and not float(value).is_integer()) or not value > 0:
        raise ConfigError(f"{key}={value!r} must be a positive {kind}")
    return int(value) if integer else float(value)


def non_negative(key: str, value: Any, integer: bool = False) -> Any:
    """``value`` >= 0 as float (or int with ``integer``)."""
    kind = "an integer" if integer else "a number"
    if not is_number(value) or (integer and not float(value).is_integer()) or not value >= 0:
        raise ConfigError(f"{key}={value!r} must be {kind} >= 0")
    return int(value) if integer else float(value)


def within(key: str, value: Any, low: float, high: float = float("inf"), closed: str = "") -> float:
    """A number in the interval from ``low`` to ``high``, open at both ends unless ``closed``
    holds ``"low"`` or ``"high"`` (``within(k, v, 0, 1, closed="high")``: (0, 1])."""
    above = value >= low if "low" in closed else value > low
    below = value <= high if "high" in closed else value < high
    if not is_number(value) or not (above and below):
        interval = f"{'[' if 'low' in closed else '('}{low:g}, {high:g}{']' if 'high' in closed else ')'}"
        raise ConfigError(f"{key}={value!r} must be a number in {interval}")
    return float(value)


def at_least(key: str, value: Any, minimum: int) -> int:
    """An integer ``value`` >= ``minimum``."""
    if not is_number(value) or not float(value).is_integer() or value < minimum:
        raise ConfigError(f"{key}={value!r} must be an integer >= {minimum}")
    return int(value)


def one_of(key: str, value: Any, allowed: Sequence[str]) -> str:
    """``value`` among ``allowed``."""
    if value not in allowed:
        raise ConfigError(f"{key}={value!r} is unknown; use one of {list(allowed)}")
    return str(value)


def flag(key: str, value: Any) -> bool:
    """A boolean ``value``."""
    if not isinstance(value, bool):
        raise ConfigError(f"{key}={value!r} must be true or false")
    return value


def instance_of(key: str, value: Any, cls: type) -> None:
    """``value`` is None (the default is used) or a ``cls``; a name given instead of a config
    group selection (``method.descriptor=pfh``) gets the fix."""
    if value is None or isinstance(value, cls):
        return
    group = key.rsplit(".", 1)[-1]
    if isinstance(value, str):
        raise ConfigError(
            f"{key}={value!r} is a name, not a {cls.__name__}; select the config with "
            f"{group}@{key}={value} (configs/{group}/{value}.yaml)"
        )
    raise ConfigError(f"{key} must be a {cls.__name__} (configs/{group}/), not {type(value).__name__}")
