"""The category templates a dataset registers to: the config's option group
(:class:`TemplateOptions`, flat keys ``templates``, ``templates_root``, ``template_points``,
``symmetric`` of every loader), the set they load (:class:`TemplateSet`) and a mesh file's entry
(:func:`template_spec`, :func:`load_template`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from catpose.datasets.dataset import OptionGroup
from catpose.datasets.meshio import MESH_SUFFIXES, mesh_to_template, read_mesh
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


class TemplateSet:
    """The configured templates of each category (``options.templates``), loaded once and kept.

    ``options.templates`` maps a category to a list of entries, each one of:

    - a mesh path (``.off``/``.obj``/``.ply``) or a mapping ``{path, up, forward, scale,
      template_id, symmetry_axis}`` (:func:`template_spec`); relative paths are resolved
      against ``options.templates_root`` (None: ``root``, the dataset's);
    - an instance id of the dataset (a string without a mesh suffix, or ``{instance: id}``),
      loaded with ``instance_loader(category, instance_id)`` (e.g. ModelNet40 training shapes).
    """

    def __init__(self, options: TemplateOptions, root: str | Path, seed: int = 0, instance_loader=None) -> None:
        self.entries = {str(k): list(v or []) for k, v in (options.templates or {}).items()}
        self.base_dir = Path(options.templates_root or root)
        self.n_points = int(options.template_points)
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
        return [i for i in map(self.instance_of, self.entries.get(category, [])) if i is not None]

    @staticmethod
    def instance_of(entry: object) -> str | None:
        """The instance id an entry names (None: a mesh path or spec)."""
        if isinstance(entry, str) and not entry.lower().endswith(MESH_SUFFIXES):
            return entry
        if not isinstance(entry, (str, Path)) and hasattr(entry, "keys") and "instance" in entry:
            return str(entry["instance"])  # type: ignore[index]
        return None

    def _load(self, category: str, entry: object) -> Template:
        instance = self.instance_of(entry)
        if instance is not None:
            if self.instance_loader is None:
                raise DatasetError(
                    f"template {instance!r} for {category!r} is not a mesh path "
                    "(.off/.obj/.ply) and this dataset has no instances to use as templates"
                )
            return self.instance_loader(category, instance)
        return load_template(category, entry, self.n_points, self.seed, self.base_dir)


#: the keys of a mesh template's config entry (:func:`template_spec`)
SPEC_KEYS = ("path", "up", "forward", "scale", "template_id", "symmetry_axis")


def template_spec(category: str, entry: object) -> dict:
    """A config entry naming a mesh file, as a mapping of :data:`SPEC_KEYS`: a path string, or a
    mapping with ``path`` and optionally ``up``, ``forward`` (the file's axes that become +z and
    +x; default ``+z``, ``+x``), ``scale`` (file units per unit), ``template_id`` (default
    ``<category>/<file stem>``) and ``symmetry_axis`` (3 numbers, template frame)."""
    if isinstance(entry, (str, Path)):
        return {"path": str(entry)}
    try:
        d = dict(entry)  # type: ignore[call-overload]
    except (TypeError, ValueError):
        raise DatasetError(f"template entry {entry!r} for {category!r} must be a path or a mapping") from None
    if "path" not in d:
        raise DatasetError(f"template entry {d} for {category!r} has no 'path'")
    unknown = set(d) - set(SPEC_KEYS)
    if unknown:
        raise DatasetError(
            f"template entry for {category!r} has unknown keys {sorted(unknown)}; allowed: {sorted(SPEC_KEYS)}"
        )
    return d


def load_template(
    category: str, entry: object, n_points: int = 2048, seed: int = 0, base_dir: str | Path | None = None
) -> Template:
    """The template (z up, x forward, unit sphere; :func:`~catpose.datasets.meshio.mesh_to_template`)
    of a mesh entry (:func:`template_spec`); a relative path is resolved against ``base_dir``."""
    d = template_spec(category, entry)
    path = Path(d["path"])
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    vertices, triangles = read_mesh(path)
    sym = d.get("symmetry_axis")
    return mesh_to_template(
        vertices,
        triangles,
        str(d.get("template_id") or f"{category}/{path.stem}"),
        category,
        n_points=n_points,
        seed=seed,
        up=str(d.get("up", "+z")),
        forward=str(d.get("forward", "+x")),
        scale=float(d.get("scale", 1.0)),
        symmetry_axis=None if sym is None else np.array([float(x) for x in sym]),
    )
