"""The one place that turns a config into objects: a group node (method, dataset, protocol)
into its ``_target_`` built with plain typed arguments, and the run-level options checked.

Methods, datasets and protocols never see a config object; everything that reads one goes
through :func:`build_from_config`. Options are checked against the constructor's annotations
before anything is built, so a wrong value is a one-line error that names its key
(``method.optimiser.lr='abc' is not a float; set method.optimiser.lr=<number>``). A constructor
argument whose default is an option group (:class:`catpose.datasets.dataset.OptionGroup`, e.g. a
dataset's ``view: ViewOptions``) takes the group's fields as flat keys (``dataset.distance=4``).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
from typing import Any

from catpose import extras, kernel_threads
from catpose.datasets.dataset import gather_option_groups, option_groups
from catpose.errors import CatposeError, ConfigError, one_line


def build_from_config(node: Any, what: str) -> tuple[str, Any]:
    """Pop ``name`` from a config group node and build its ``_target_`` with the rest.

    Every user mistake becomes a one-line :class:`ConfigError` naming the key: a missing
    mandatory value, an option the target does not take, a value of the wrong type for a
    constructor argument annotated ``float``/``int``/``bool``/``str`` (see
    :func:`check_constructor_args`), and any other ``TypeError``/``ValueError`` of the constructor.
    """
    from hydra.utils import instantiate
    from omegaconf import OmegaConf
    from omegaconf.errors import MissingMandatoryValue

    check_missing(node, what)
    try:
        d = OmegaConf.to_container(node, resolve=True) if not isinstance(node, dict) else dict(node)
    except MissingMandatoryValue as e:
        raise ConfigError(f"{what}: a required value is missing ({e}); set it on the command line") from None
    name = str(d.pop("name", what))
    if "_target_" not in d:
        raise ConfigError(f"config group '{what}' ({name}) has no _target_; add one to configs/{what}/{name}.yaml")
    check_constructor_args(d, what, name)
    try:
        rest, groups = gather_option_groups(d)
        if not groups:
            return name, instantiate(d, _convert_="all")
        return name, instantiate({**rest, "_partial_": True}, _convert_="all")(**groups)
    except CatposeError:
        raise
    except Exception as e:  # Hydra wraps constructor errors; surface the user-facing one
        cause = e
        while cause.__cause__ is not None:
            cause = cause.__cause__
        if isinstance(cause, CatposeError):
            raise cause from None
        missing = extras.missing_extra(cause)
        if missing is not None:  # an optional dependency the configuration needs (catpose.extras)
            raise missing from None
        named = [k for k in d if not k.startswith("_") and re.search(rf"\b{re.escape(k)}\b", str(cause))]
        keys = ", ".join(f"{what}.{k}={d[k]!r}" for k in named) or f"the {what}.* values"
        raise ConfigError(
            f"cannot build {what} '{name}' ({d['_target_']}): {one_line(cause)}; "
            f"check {keys} (bench run --cfg job shows them)"
        ) from None


def build_dataset(node: Any) -> Any:
    """The dataset of a config's ``dataset`` node (:func:`build_from_config`), named as the config
    names it (``dataset.name``: run directories and tables use it)."""
    name, dataset = build_from_config(node, "dataset")
    dataset.name = name
    return dataset


def build_parts(cfg: Any) -> tuple[str, Any, Any, Any]:
    """(method name, method, dataset, protocol) of a composed run config, built as a run builds them."""
    method_name, method = build_from_config(cfg.method, "method")
    dataset = build_dataset(cfg.dataset)
    return method_name, method, dataset, build_protocol(cfg)


def _node(cfg: Any, key: str) -> dict | None:
    """``cfg[key]`` (a composed config or a ``config.yaml`` read as a dict) as a plain dict, or None."""
    from omegaconf import DictConfig, OmegaConf

    node = cfg.get(key) if hasattr(cfg, "get") else None
    if isinstance(node, DictConfig):
        return OmegaConf.to_container(node, resolve=True)
    return dict(node) if isinstance(node, dict) else None


def target_class(node: Any) -> Any:
    """What a config node's ``_target_`` names, None where it names nothing importable (building
    then says why)."""
    module_name, _, attr = str(node.get("_target_", "") if hasattr(node, "get") else "").rpartition(".")
    try:
        return getattr(importlib.import_module(module_name), attr, None)
    except (ImportError, ValueError):
        return None


def takes_choice(protocol: Any) -> bool:
    """Whether a protocol config node's class keeps one of a view's template registrations (its
    constructor takes ``choice``: templates, relative), so the ``choice`` group applies to it."""
    try:
        return "choice" in inspect.signature(target_class(protocol)).parameters
    except (ValueError, TypeError):
        return False


def build_choice(cfg: Any) -> Any | None:
    """The run's template choice (:class:`catpose.methods.template_choice.TemplateChoice`) from its
    ``choice`` group. None when the protocol keeps no choice (``gt_model``)."""
    if not takes_choice(_node(cfg, "protocol") or {}):
        return None
    return build_from_config(_choice_node(cfg), "choice")[1]


def _choice_node(cfg: Any) -> dict:
    choice = _node(cfg, "choice")
    if choice is None:
        raise ConfigError(
            "the config has no choice; set choice=<name> (bench run --help), "
            "or re-run an older run to rewrite its config.yaml"
        )
    return choice


#: the rule the protocols read of the ``choice`` group (configs/choice/*.yaml)
RULE_TARGET = "catpose.methods.choice_rules.ChoiceRule"


def build_protocol(cfg: Any) -> Any:
    """The protocol of a composed run config or a run directory's ``config.yaml``; one that keeps a
    view's template (:func:`takes_choice`) gets the ``choice`` group's rule and weights
    (:class:`catpose.methods.choice_rules.ChoiceRule`)."""
    from dataclasses import fields

    from catpose.methods.choice_rules import ChoiceRule

    node = _node(cfg, "protocol")
    if node is None:
        raise ConfigError("the config has no protocol; set protocol=<name> (bench run --help)")
    if takes_choice(node):
        rule_keys = {f.name for f in fields(ChoiceRule)}
        node["choice"] = {"_target_": RULE_TARGET, **{k: v for k, v in _choice_node(cfg).items() if k in rule_keys}}
    return build_from_config(node, "protocol")[1]


def check_missing(node: Any, what: str) -> None:
    """A one-line :class:`ConfigError` naming the mandatory (``???``) keys of a group left unset."""
    from omegaconf import OmegaConf

    if isinstance(node, dict):
        return
    # missing_keys of a child node gives full paths ("dataset.root"); keep them relative
    missing = sorted(k.removeprefix(f"{what}.") for k in OmegaConf.missing_keys(node))
    if missing:
        raise ConfigError(
            f"{what} needs {', '.join(f'{what}.{k}' for k in missing)}: "
            f"set it on the command line, e.g. {what}.{missing[0]}=<value>"
        )


# annotation (as written, `from __future__ import annotations` keeps it a string) -> what it accepts
_SCALAR_HINTS = {"float": "<number>", "int": "<integer>", "bool": "<true|false>", "str": "<text>"}


def _scalar_annotation(annotation: Any) -> set[str] | None:
    """The scalar types an annotation allows (``"float | None"`` -> {"float", "None"}), or None
    when it is anything else (containers, classes, unannotated): those are not checked."""
    if annotation is inspect.Parameter.empty:
        return None
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    text = str(text).replace("typing.", "")
    optional = text.startswith("Optional[")
    if optional:
        text = text.removeprefix("Optional[").removesuffix("]")
    parts = {"None" if p.strip() in ("None", "NoneType") else p.strip() for p in text.split("|")}
    if optional:
        parts.add("None")
    return parts if parts <= {*_SCALAR_HINTS, "None"} and parts - {"None"} else None


def _accepts(kinds: set[str], value: Any) -> bool:
    """Whether ``value`` (as Hydra parsed it) fits one of the scalar ``kinds``."""
    if value is None:
        return "None" in kinds
    if isinstance(value, bool):
        return "bool" in kinds
    if isinstance(value, int):
        return bool(kinds & {"int", "float", "str"}) or ("bool" in kinds and value in (0, 1))
    if isinstance(value, float):
        return "float" in kinds or "str" in kinds or ("int" in kinds and value.is_integer())
    if isinstance(value, str):
        return "str" in kinds
    return False


def _target_parameters(target_name: str) -> dict[str, inspect.Parameter]:
    """The options of a ``_target_``: its constructor's parameters, each option group replaced by
    its fields (:func:`catpose.datasets.dataset.option_groups`)."""
    params, groups = option_groups(target_name)
    for key, default in groups.items():
        del params[key]
        for f in dataclasses.fields(default):
            params[f.name] = inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, annotation=f.type)
    return params


def check_constructor_args(d: dict, what: str, name: str) -> None:
    """Check a group's options against its ``_target_``'s constructor before building it.

    Raises a one-line :class:`ConfigError` for an option the constructor does not take (unless
    it has ``**kwargs``) and, outside the methods (which check their own arguments with
    :mod:`catpose.methods.options`), for a value that does not fit a parameter annotated with scalar
    types only (``float``, ``int``, ``bool``, ``str``, optionally ``| None``), e.g.
    ``dataset.width='abc' is not an int; set dataset.width=<integer>``. Anything the check cannot read
    (an unimportable target, container annotations) is left to the constructor.
    """
    try:
        params = _target_parameters(str(d["_target_"]))
    except (ImportError, AttributeError, ValueError, TypeError):
        return  # Hydra reports an unknown target itself
    takes_kwargs = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    for key, value in d.items():
        if key.startswith("_"):
            continue
        if isinstance(value, dict) and "_target_" in value:  # a nested settings object: its own keys
            check_constructor_args(value, f"{what}.{key}", name)
        if key not in params:
            if not takes_kwargs:
                options = ", ".join(k for k, p in params.items() if p.kind is not inspect.Parameter.VAR_POSITIONAL)
                raise ConfigError(
                    f"{what}.{key} is not an option of {what} '{name}' ({d['_target_']}); options: {options}"
                )
            continue
        kinds = None if what.startswith("method") else _scalar_annotation(params[key].annotation)
        if kinds is not None and not _accepts(kinds, value):
            main = next(k for k in ("float", "int", "bool", "str") if k in kinds)
            article = "an" if main == "int" else "a"
            or_null = " or null" if "None" in kinds else ""
            raise ConfigError(
                f"{what}.{key}={value!r} is not {article} {main}{or_null}; set {what}.{key}={_SCALAR_HINTS[main]}"
            )


def _run_option(cfg: Any, key: str, kind: str, minimum: int | float | None = None) -> Any:
    """``cfg[key]`` validated as ``kind`` ("int" or "float", None allowed), at least ``minimum``;
    a one-line :class:`ConfigError` naming the key and the fix otherwise (``limit=-1``,
    ``limit=abc`` and ``seed=1.5`` must not become something else silently)."""
    value = cfg.get(key)
    if value is None:
        return None
    ok = not isinstance(value, bool) and (isinstance(value, int) or (kind == "float" and isinstance(value, float)))
    if not ok or (minimum is not None and value < minimum):
        need = "an integer" if kind == "int" else "a number"
        bound = f" >= {minimum}" if minimum is not None else ""
        raise ConfigError(
            f"{key}={value!r} is not {need}{bound}; set {key}=<{'integer' if kind == 'int' else 'number'}"
            f"{bound}> (or drop it)"
        )
    return value


def validate_run_options(cfg: Any) -> None:
    """Check the run-level keys (``seed``, ``limit``, ``threads`` (or ``auto``), ``batch``, ``lock_timeout``) and that no
    mandatory group key (``dataset.root``) is unset, before any work."""
    if cfg.get("seed") is None:
        raise ConfigError("seed is not set; set seed=<integer>, e.g. seed=0")
    _run_option(cfg, "seed", "int")
    _run_option(cfg, "limit", "int", 1)
    threads = cfg.get("threads")
    if threads is not None:  # null: the kernels take 1, torch keeps its count
        try:
            kernel_threads.resolve(threads)
        except ValueError:
            raise ConfigError(
                f"threads={threads!r} is not {kernel_threads.AUTO} or an integer >= 1; set threads={kernel_threads.AUTO} "
                "(the CPUs this process may use) or threads=<integer >= 1>"
            ) from None
    _run_option(cfg, "batch", "int", 1)
    _run_option(cfg, "lock_timeout", "float", 0)
    ids = cfg.get("sample_ids")
    if ids is not None and (isinstance(ids, str) or not hasattr(ids, "__len__") or len(ids) == 0):
        raise ConfigError(
            f"sample_ids={ids!r} lists no sample; give a list of sample ids (sample_ids=[mug/000/v00]), or drop it "
            "to run every sample"
        )
    for group in ("method", "dataset", "protocol", "choice"):
        if group in cfg:
            check_missing(cfg[group], group)
