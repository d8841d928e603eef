"""The dataset interface: observations, complete models and category templates."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from catpose.types import DepthImage, Template

if TYPE_CHECKING:
    from catpose.datasets.layout_check import LayoutReport


@dataclass(frozen=True, eq=False)
class Observation:
    """One partial view of one object instance.

    Attributes:
        obs_id: unique, stable id within the dataset, e.g. ``"chair/0003/v02"``.
        category: category name.
        instance_id: id of the observed instance within its category.
        points_camera: (N, 3) observed points, camera frame, object-normalised unit.
        normals_camera: (N, 3) unit normals, oriented towards the camera.
        ground_normal_camera: (3,) unit up direction in the camera frame (known or estimated).
        T_object_camera: (4, 4) true camera pose in the instance's canonical frame. For data
            whose object frame is unknown (a Redwood trajectory) it is the pose in a frame shared
            by all views of that instance, and ``info["absolute_gt"]`` is False: only relative
            poses can be scored.
        symmetry_axis: (3,) main axis in the object frame if the object is rotationally
            symmetric (scored by main-axis error), else None.
        symmetries: discrete symmetries of the object, (4, 4) transforms of the object frame
            that map it onto itself (e.g. BOP ``symmetries_discrete``); scored as equivalent.
        info: facts for the per-sample table (view id, mask source, ...).
        depth_image: the depth image (object-normalised unit), intrinsics and object mask the
            points came from, where the view is an image (:class:`~catpose.types.DepthImage`);
            None for clouds without one.
    """

    obs_id: str
    category: str
    instance_id: str
    points_camera: np.ndarray
    normals_camera: np.ndarray
    ground_normal_camera: np.ndarray
    T_object_camera: np.ndarray
    symmetry_axis: np.ndarray | None = None
    info: Mapping[str, Any] = field(default_factory=dict)
    symmetries: tuple = ()
    depth_image: DepthImage | None = None


class OptionGroup:
    """Base of the option dataclasses a dataset's constructor takes as one argument and whose fields
    a config gives as flat keys of its group (:mod:`catpose.datasets.views`)."""


def option_groups(target_name: str) -> tuple[dict[str, inspect.Parameter], dict[str, Any]]:
    """A ``_target_``'s constructor parameters and its option groups: the parameters whose default is
    a :class:`catpose.datasets.dataset.OptionGroup` (name -> that default), whose fields a config gives
    as flat keys of the group. Raises ImportError, AttributeError, ValueError or TypeError when the
    target cannot be read."""
    module_name, _, attr = target_name.rpartition(".")
    params = dict(inspect.signature(getattr(importlib.import_module(module_name), attr)).parameters)
    return params, {k: p.default for k, p in params.items() if isinstance(p.default, OptionGroup)}


def gather_option_groups(d: dict) -> tuple[dict, dict]:
    """``d`` without the flat keys of its target's option groups, and the groups built from them
    over the constructor's defaults (parameter -> group object)."""
    try:
        groups = option_groups(str(d["_target_"]))[1]
    except (ImportError, AttributeError, ValueError, TypeError):
        return d, {}
    rest = dict(d)
    for key, default in groups.items():
        given = {f.name: rest.pop(f.name) for f in dataclasses.fields(default) if f.name in rest}
        groups[key] = dataclasses.replace(default, **given)
    return rest, groups


class ObjectDataset(ABC):
    """A set of observations plus the complete models and templates to register them to.

    Implementations load lazily: ``observation_ids`` must be cheap and deterministic, and a bad
    file surfaces as a :class:`~catpose.errors.DatasetError` from ``observation`` (the runner
    records that sample as failed and goes on).
    """

    name: str = "dataset"
    #: The instances of a category share one canonical frame, so a template (another instance)
    #: and an observation's ground truth are in the same frame. Category-level protocols
    #: (``templates``, ``relative`` with category templates) refuse datasets where this is False
    #: (raw ModelNet40 without an alignment table: its instances differ by multiples of 90 deg
    #: of yaw). True for data whose frames are consistent by construction (the synthetic set)
    #: or whose templates are the observed objects' own models (BOP).
    frames_consistent: bool = True
    #: Why ``bench data check`` has no root to check (the data are generated), or None.
    generated: str | None = None

    @abstractmethod
    def observation_ids(self) -> list[str]:
        """All observation ids in a fixed order."""

    def category_of(self, obs_id: str) -> str:
        """The category of an observation without loading it. Ids start with the category
        (``"chair/..."``) by convention; override when they do not."""
        return obs_id.split("/", 1)[0]

    def check_layout(self, name: str, report: LayoutReport) -> None:  # noqa: B027 - optional, a no-op here
        """Walk the root's layout for ``bench data check`` (config name ``name``), adding what is
        wrong to ``report``; the check then lists the samples and loads the first. None here."""

    @abstractmethod
    def observation(self, obs_id: str) -> Observation:
        """Load or render one observation."""

    @abstractmethod
    def instance_model(self, category: str, instance_id: str) -> Template:
        """The observed instance's own complete model in its canonical frame (``gt_model``
        protocol). Raises :class:`~catpose.errors.DatasetError` when the dataset has none."""

    @abstractmethod
    def category_templates(self, category: str) -> list[Template]:
        """The configured category templates (``templates`` protocol), in a fixed order."""
