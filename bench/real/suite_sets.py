"""The sets and method rows of ``bench suite`` (:mod:`catpose.bench.real.suite`): the real sets of
the shared data (:data:`SETS`), the cluttered synthetic sets (:data:`CLUTTER_SETS`), the method rows
from the method registry (:data:`METHODS`), and why a set or a row cannot run here."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class RealSet:
    """One real data set: its dataset config, the overrides pointing it at the shared data
    (``{shared}`` is replaced by the shared-data folder) and the path that must exist."""

    name: str
    dataset: str
    requires: str
    overrides: tuple[str, ...] = ()
    protocol: str = "gt_model"
    needs_trajectory: bool = False
    split: str | None = None  # configs/split/<split>.yaml: one table column per part
    parts: tuple[str, ...] = ()  # load only these parts' scenes (empty: every frame)


@dataclass(frozen=True)
class MethodVariant:
    """A table row: a method config and its overrides."""

    label: str
    method: str
    overrides: tuple[str, ...] = field(default_factory=tuple)
    requires: str | None = None  # an optional module (an extra) without which the row is skipped, said why


#: the YCB-V categories scored by their main axis (up, +z) with category templates: another
#: instance's model fixes no forward direction of this one
MAIN_AXIS = tuple(f"+dataset.symmetric.{c}=[0,0,1]" for c in ("can", "bottle", "bowl", "mug"))

#: the seeds every suite runs by default (a cell: their mean, with min and max)
SEEDS = (0, 1, 2)

SETS: dict[str, RealSet] = {
    s.name: s
    for s in (
        RealSet("ycbv", "ycbv", "bop/ycbv", ("dataset.root={shared}/bop/ycbv",), split="ycbv"),
        # the paper's real-data protocols on the same frames: each view registered to its category's
        # templates (the other YCB-V models of the category), scored by the main axis as the paper's
        # TYO-L table; and the relative pose of two frames of one scene, each registered to them
        RealSet("ycbv_templates", "ycbv", "bop/ycbv", ("dataset.root={shared}/bop/ycbv", *MAIN_AXIS), "templates"),
        RealSet("ycbv_relative", "ycbv", "bop/ycbv", ("dataset.root={shared}/bop/ycbv",), "relative"),
        RealSet("tyol", "bop", "bop/tyol", ("dataset.root={shared}/bop/tyol",)),
        RealSet(
            "modelnet40_resampled",
            "modelnet40_resampled",
            "modelnet40_normal_resampled",
            ("dataset.root={shared}/modelnet40_normal_resampled",),
        ),
        RealSet(
            "redwood",
            "redwood",
            "redwood",
            ("dataset.root={shared}/redwood",),
            protocol="relative",
            needs_trajectory=True,
        ),
    )
}

#: the cluttered synthetic set of the real YCB-V meshes (datasets/clutter.py): where ours' choices are made
CLUTTER_SETS: dict[str, RealSet] = {
    s.name: s
    for s in (
        RealSet(
            "clutter",
            "clutter",
            "bop/ycbv/models",
            ("dataset.root={shared}/bop/ycbv",),
            split="clutter",
            parts=("report",),
        ),
        RealSet(
            "clutter_objects",
            "clutter",
            "bop/ycbv/models",
            ("dataset.root={shared}/bop/ycbv",),
            split="clutter_objects",
            parts=("report_A", "report_B"),
        ),
    )
}

SUITES: dict[str, dict[str, RealSet]] = {"real": SETS, "clutter": CLUTTER_SETS}


def _variants() -> dict[str, MethodVariant]:
    """Every method's rows, from the method registry (:attr:`catpose.methods.registry.MethodSpec.suite`),
    in the order of their ranks."""
    from catpose.methods.registry import registered

    rows = sorted(((r, s) for s in registered().values() for r in s.suite_rows()), key=lambda rs: rs[0].rank)
    return {r.label: MethodVariant(r.label, s.name, r.overrides, s.requires) for r, s in rows}


METHODS: dict[str, MethodVariant] = _variants()


def missing_extra(variant: MethodVariant) -> str | None:
    """Why a method row cannot run here (its optional module is not importable), or None."""
    if not variant.requires:
        return None
    import importlib

    try:
        importlib.import_module(variant.requires)
    except ImportError:
        return f"{variant.requires} is not importable (install the extra: pip install -e '.[{variant.method}]')"
    return None


def skip_reason(real_set: RealSet, shared: Path) -> str | None:
    """Why a set cannot be run and scored here (None: it can)."""
    root = shared / real_set.requires
    if not root.exists():
        return f"{root} is absent"
    if real_set.needs_trajectory and not any(root.rglob("*.log")):
        return (
            f"no camera trajectory (*.log) under {root}: Redwood frames have no object pose, only "
            "relative poses from a trajectory can be scored"
        )
    return None
