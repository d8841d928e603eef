"""The method registry: each method module registers its class with what the rest of catpose asks
of it, so that adding a method is its module and its config (``configs/method/<name>.yaml``), and
no list elsewhere (small_gicp's benchmark: each engine one file that registers itself).

The report's labels (:attr:`MethodSpec.display_name`), ``bench suite real`` (:attr:`MethodSpec.suite`),
the API's up search and template preparation (:func:`needs_up`, :func:`prepare`) and the method
tests (:attr:`MethodSpec.smoke_options`) read it.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple


class SuiteRow(NamedTuple):
    """One row of ``bench suite real|clutter``: its label, the overrides of the method's config
    (Hydra syntax, ``method.matching=dictionary``) and its place among the rows (lowest first)."""

    label: str
    overrides: tuple[str, ...] = ()
    rank: float = 100.0


@dataclass(frozen=True)
class MethodSpec:
    """What catpose knows of a method besides its class.

    Attributes:
        name: its config, ``configs/method/<name>.yaml`` (``method=<name>``).
        cls: the class that config's ``_target_`` builds.
        display_name: its name in tables and legends (``Ours``, ``ICP``).
        uses_up: whether it reads the ground normal (then the API searches up directions when the
            caller gives none): a bool, or a function of the built method (a baseline on LPS features).
        prepare_template: builds the method's per-template data ahead of the first registration
            (``prepare_template(method, template)``); None: the method builds it on its first call.
        suite: its rows of ``bench suite real|clutter``; None: one row named after the method.
        requires: a module it needs that is an optional extra (``cv2.ppf_match_3d``), or None.
        smoke_options: keyword options for the tiny known-transform test (tests/test_methods.py):
            quick and sure on one small partial view of a procedural chair.
    """

    name: str
    cls: type
    display_name: str
    uses_up: bool | Callable[[Any], bool] = False
    prepare_template: Callable[[Any, Any], None] | None = None
    suite: tuple[SuiteRow, ...] | None = None
    requires: str | None = None
    smoke_options: Mapping[str, Any] = field(default_factory=dict)

    def suite_rows(self) -> tuple[SuiteRow, ...]:
        return (SuiteRow(self.name),) if self.suite is None else self.suite


_REGISTRY: dict[str, MethodSpec] = {}


def register_method(name: str, display_name: str, **spec: Any) -> Callable[[type], type]:
    """Class decorator: ``@register_method("icp", "ICP")`` records the class as ``method=icp``
    (the other :class:`MethodSpec` fields as keywords)."""

    def record(cls: type) -> type:
        _REGISTRY[name] = MethodSpec(name, cls, display_name, **spec)
        return cls

    return record


def registered() -> dict[str, MethodSpec]:
    """Every method, by config name, in the order of their names. Imports every module of
    :mod:`catpose.methods` once, so that each has registered itself."""
    import catpose.methods as package

    for module in pkgutil.iter_modules(package.__path__):
        importlib.import_module(f"{package.__name__}.{module.name}")
    return dict(sorted(_REGISTRY.items()))


def spec_of(method: Any) -> MethodSpec | None:
    """The spec of a built method: its class's, or the nearest registered base class's (None: an
    unregistered class, such as a user's own :class:`~catpose.methods.method.RegistrationMethod`)."""
    by_class = {s.cls: s for s in registered().values()}
    return next((by_class[c] for c in type(method).__mro__ if c in by_class), None)


def needs_up(method: Any) -> bool:
    """Whether the built ``method`` reads the ground normal (its spec's ``uses_up``; ours, a baseline
    on LPS features): then the API searches up directions when the caller gives none."""
    spec = spec_of(method)
    return spec is not None and bool(spec.uses_up(method) if callable(spec.uses_up) else spec.uses_up)


def prepare(method: Any, template: Any) -> None:
    """Build ``method``'s per-template data for ``template`` (object-normalised) now instead of on
    its first registration, where its spec has a ``prepare_template`` (ours: dictionaries,
    descriptors, ray caster, loaded from the disk cache when there)."""
    spec = spec_of(method)
    if spec is not None and spec.prepare_template is not None:
        spec.prepare_template(method, template)
