"""The category templates a dataset registers to: the config's option group
(:class:`TemplateOptions`, flat keys ``templates``, ``templates_root``, ``template_points``,
``symmetric`` of every loader) and the set they load (:class:`TemplateSet`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from catpose.datasets.dataset import OptionGroup
from catpose.datasets.meshio import MESH_SUFFIXES, load_template, template_spec_from_dict
from catpose.errors import DatasetError
from catpose.types import Template


@dataclass(frozen=True)
class TemplateOptions(OptionGroup):
    """The category templates and complete models a dataset registers to.

    Attributes:
        templates: category -> template entries (instance ids or mesh specs, see
            :class:`TemplateSet`).
        templates_root: base folder of relative template mesh paths (None: the dataset's root).
        template_points: points sampled on each complete model / template.
        symmetric: category -> main axis (template frame) of rotationally symmetric categories
            (scored by main-axis error).
    """

    templates: dict[str, list] | None = None
    templates_root: str | None = None
    template_points: int = 2048
    symmetric: dict[str, list[float]] | None = None

    def symmetry_axes(self) -> dict[str, np.ndarray]:
        """category -> (3,) main axis, float64."""
        return {k: np.asarray(v, float) for k, v in (self.symmetric or {}).items()}

    def template_set(self, root: str | Path, seed: int, instance_loader=None) -> TemplateSet:
        """The templates, relative paths under ``templates_root`` (None: ``root``); an instance-id
        entry is loaded by ``instance_loader(category, instance_id)``."""
        return TemplateSet(
            self.templates,
            self.templates_root or root,
            int(self.template_points),
            seed,
            instance_loader=instance_loader,
        )


class TemplateSet:
    """The configured templates of each category, loaded once and kept.

    ``entries`` maps a category to a list of entries, each one of:

    - a mesh path (``.off``/``.obj``/``.ply``) or a mapping ``{path, up, forward, scale,
      template_id, symmetry_axis}`` (see :class:`TemplateSpec`); relative paths are resolved
      against ``base_dir``;
    - an instance id of the dataset (a string without a mesh suffix, or ``{instance: id}``),
      loaded with ``instance_loader(category, instance_id)`` (e.g. ModelNet40 training shapes).
    """

    def __init__(
        self,
        entries: dict | None,
        base_dir: str | Path | None,
        n_points: int = 2048,
        seed: int = 0,
        instance_loader=None,
    ) -> None:
        self.entries = {str(k): list(v or []) for k, v in (entries or {}).items()}
        self.base_dir = None if base_dir is None else Path(base_dir)
        self.n_points = int(n_points)
        self.seed = int(seed)
        self.instance_loader = instance_loader
        self._cache: dict[str, list[Template]] = {}

    def get(self, category: str) -> list[Template]:
        """Templates of ``category`` in config order ([] when none are configured)."""
        if category not in self._cache:
            self._cache[category] = [self._load(category, e) for e in self.entries.get(category, [])]
        return self._cache[category]

    def instance_ids(self, category: str) -> list[str]:
        """The dataset instance ids among ``category``'s template entries (meshes left out)."""
        return [i for i in map(self._instance, self.entries.get(category, [])) if i is not None]

    @staticmethod
    def _instance(entry: object) -> str | None:
        """The instance id an entry names (None: a mesh path or spec)."""
        if isinstance(entry, str) and not entry.lower().endswith(MESH_SUFFIXES):
            return entry
        if not isinstance(entry, (str, Path)) and hasattr(entry, "keys") and "instance" in entry:
            return str(entry["instance"])  # type: ignore[index]
        return None

    def _load(self, category: str, entry: object) -> Template:
        instance = self._instance(entry)
        if instance is not None:
            if self.instance_loader is None:
                raise DatasetError(
                    f"template {instance!r} for {category!r} is not a mesh path "
                    "(.off/.obj/.ply) and this dataset has no instances to use as templates"
                )
            return self.instance_loader(category, instance)
        spec = template_spec_from_dict(category, entry)
        return load_template(spec, n_points=self.n_points, seed=self.seed, base_dir=self.base_dir)
