"""ModelNet40 meshes in the official layout, with rendered partial views.

Layout: ``<root>/<category>/<split>/<category>_<id>.off`` (``.OFF`` too; Princeton ModelNet40, or the
aligned release of Sedaghat et al., which has the same layout: set ``aligned: true``). OFF files
with ``OFF`` and the counts on one line are read (trimesh, :func:`catpose.datasets.meshio.read_mesh`).

Each shape is rotated so that the configured ``up``/``forward`` file axes become +z/+x, rotated
by its entry in the optional alignment table (:mod:`catpose.datasets.alignment`; raw ModelNet40
instances differ by multiples of 90 degrees of yaw), and normalised to the unit bounding sphere
at its bounding-box centre: the object frame of every observation, in which translation errors
are measured. Partial views are rendered with :mod:`catpose.datasets.render` from viewpoints of
a :class:`~catpose.datasets.views.ViewOptions` with the synthetic set's knobs; the view of
``obs_id`` is a deterministic function of ``(seed, obs_id)``, made in the order every dataset
uses: render, noise, subsample to ``max_points``, normals (as a method would estimate them from
a downsampled scan).

Observation ids: ``<category>/<instance_id>/v<k>``, e.g. ``airplane/airplane_0001/v02``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from catpose.datasets.alignment import read_alignment_table
from catpose.datasets.dataset import ObjectDataset, Observation, OptionGroup
from catpose.datasets.layout_check import LayoutReport, check_templates
from catpose.datasets.meshio import R_template_file, read_mesh, sampled_template
from catpose.datasets.render import depth_to_points, render_depth
from catpose.datasets.templates import TemplateOptions, TemplateSet
from catpose.datasets.views import ImageOptions, ViewOptions, check_counts, kept_view, view_observation
from catpose.errors import CatposeError, DatasetError
from catpose.geometry import apply_R, matmul3, normalize_to_unit_sphere, stable_seed
from catpose.types import DepthImage, Template


@dataclass(frozen=True)
class ShapeFrame(OptionGroup):
    """How a file's shape becomes the canonical object frame (z up, x forward).

    Attributes:
        up, forward: the files' axes that become +z and +x.
        aligned: the shapes are already consistently oriented (Sedaghat et al. release).
        alignment_table: CSV of per-instance rotations (:mod:`catpose.datasets.alignment`;
            ignored when ``aligned``).
    """

    up: str = "+z"
    forward: str = "+x"
    aligned: bool = False
    alignment_table: str | None = None


class ModelNetBase(ObjectDataset):
    """What the two ModelNet40 releases share: root, split and instance selection, views per
    instance, the file-to-canonical rotation (file axes, then the optional per-instance alignment
    table), templates and symmetric categories. Subclasses read their own file format and say in
    ``missing_root`` what their root holds."""

    missing_root = "{root} is not a folder; set dataset.root"

    def __init__(
        self,
        root: str,
        split: str,
        instances_per_category: int | None,
        views_per_instance: int,
        view: ViewOptions,
        template: TemplateOptions,
        template_split: str,
        frame: ShapeFrame,
        seed: int,
    ) -> None:
        check_counts(views_per_instance=views_per_instance, instances_per_category=instances_per_category)
        self.root = Path(root)
        if not self.root.is_dir():
            raise DatasetError(self.missing_root.format(root=self.root))
        self.split = str(split)
        self.instances_per_category = instances_per_category
        self.views_per_instance = int(views_per_instance)
        self.view = view
        self.template_points = int(template.template_points)
        self.template_split = str(template_split)
        self.aligned = bool(frame.aligned)
        self.alignment_table = None if frame.aligned or not frame.alignment_table else str(frame.alignment_table)
        self.alignment = {} if self.alignment_table is None else read_alignment_table(self.alignment_table)
        # raw ModelNet40 instances differ by multiples of 90 deg of yaw: consistent only when
        # aligned (Sedaghat et al. release) or given a per-instance alignment table that covers
        # every instance in use (check_alignment_covers, at the end of the subclass's __init__)
        self.frames_consistent = self.aligned or self.alignment_table is not None
        self.R_template_file = R_template_file(frame.up, frame.forward)
        self.symmetric = template.symmetry_axes()
        self.seed = int(seed)
        self._templates = TemplateSet(template, self.root, self.seed, self.instance_model)
        self._ids: list[str] | None = None

    def check_alignment_covers(self, wanted: dict[str, list[str]] | None = None) -> None:
        """With an alignment table: refuse it in one line unless it has a row for every instance in
        ``wanted`` (category -> ids; default: every instance the observations and the instance-id
        templates of the dataset's categories use). A table for another category, or with ids that
        match nothing, would otherwise leave those instances in their raw frames while the dataset
        declares its frames consistent."""
        if self.alignment_table is None:
            return
        if wanted is None:
            wanted = {}
            try:
                obs = self.observation_ids()
            except DatasetError:  # no observations (a split without files): the templates still count
                obs = []
            for obs_id in obs:
                category, instance_id, _ = obs_id.split("/")
                wanted.setdefault(category, [])
                if instance_id not in wanted[category]:
                    wanted[category].append(instance_id)
            for category in list(self.categories or wanted):
                for i in self._templates.instance_ids(category):
                    if i not in wanted.setdefault(category, []):
                        wanted[category].append(i)
        for category, ids in wanted.items():
            missing = [i for i in ids if (category, i) not in self.alignment]
            if missing:
                have = ", ".join(sorted({c for c, _ in self.alignment})) or "nothing"
                raise DatasetError(
                    f"alignment table {self.alignment_table} has no row for {len(missing)} of the {len(ids)} "
                    f"{category} instances used (e.g. {missing[0]}; the table covers {have}); add them "
                    f"(experiments/alignment/align.py --category {category}), keep dataset.categories to the "
                    "table's, or unset dataset.alignment_table"
                )

    def canonical_rotation(self, category: str, instance_id: str) -> np.ndarray:
        """(3, 3) rotation from the file's frame into the canonical object frame (z up, x forward)."""
        R = self.alignment.get((category, instance_id))
        return self.R_template_file if R is None else matmul3(R, self.R_template_file)

    def category_templates(self, category: str) -> list[Template]:
        return self._templates.get(category)

    def instances(self) -> dict[str, list[str]]:
        """category -> the instance ids observed (the split's, at most ``instances_per_category``)."""
        raise NotImplementedError

    def observation_ids(self) -> list[str]:
        if self._ids is None:
            by_category = self.instances()
            self._ids = [
                f"{c}/{i}/v{k:02d}"
                for c, ids in by_category.items()
                for i in ids
                for k in range(self.views_per_instance)
            ]
            if not self._ids:
                raise DatasetError(
                    f"no {self.split}-split instances under {self.root} for categories {list(by_category)}; "
                    "check dataset.root, dataset.split and dataset.categories"
                )
        return self._ids

    def aligned_instance(self, category: str, instance_id: str) -> bool:
        """Whether the instance's frame is the category's (the aligned release, or a table row)."""
        return self.aligned or (category, instance_id) in self.alignment

    @staticmethod
    def parse(obs_id: str) -> tuple[str, str, str]:
        """``(category, instance_id, view)`` of an observation id."""
        try:
            category, instance_id, view = obs_id.split("/")
        except ValueError:
            raise DatasetError(f"observation id {obs_id!r} is not <category>/<instance>/v<k>") from None
        return category, instance_id, view


def _off_files(folder: Path) -> dict[str, Path]:
    """A folder's OFF meshes by stem, their suffix in any case (some copies write ``.OFF``)."""
    return {p.stem: p for p in sorted(folder.iterdir()) if p.suffix.lower() == ".off"} if folder.is_dir() else {}


class ModelNet40(ModelNetBase):
    """ModelNet40 OFF meshes and partial views rendered from them.

    Args:
        root: folder holding ``<category>/<split>/*.off``.
        categories: categories to use (None: every folder under ``root``).
        split: ``"train"`` or ``"test"``.
        instances_per_category: use only the first N instances of each category (None: all).
        views_per_instance: rendered views per instance.
        view: viewpoints, depth noise, points kept (:class:`~catpose.datasets.views.ViewOptions`).
        image: image size, intrinsics, normal radius, ``min_points`` (:class:`~catpose.datasets.views.ImageOptions`).
        template: templates, their root, points per model, symmetric categories
            (:class:`~catpose.datasets.templates.TemplateOptions`).
        template_split: the split that instance-id templates come from.
        frame: file axes, ``aligned`` and the alignment table (:class:`ShapeFrame`).
        seed: fixes every view.
    """

    name = "modelnet40"
    missing_root = (
        "ModelNet40 root {root} is not a folder; set dataset.root to the folder that holds <category>/<split>/*.off"
    )

    def __init__(
        self,
        root: str,
        categories: list[str] | None = None,
        split: str = "test",
        instances_per_category: int | None = None,
        views_per_instance: int = 5,
        view: ViewOptions = ViewOptions(),
        image: ImageOptions = ImageOptions(),
        template: TemplateOptions = TemplateOptions(),
        template_split: str = "train",
        frame: ShapeFrame = ShapeFrame(),
        seed: int = 0,
    ) -> None:
        super().__init__(
            root, split, instances_per_category, views_per_instance, view, template, template_split, frame, seed
        )
        self.categories = (
            sorted(categories) if categories else sorted(p.name for p in self.root.iterdir() if p.is_dir())
        )
        self.image = image
        self.camera = image.camera()
        self._meshes: dict[tuple[str, str, str], tuple[np.ndarray, np.ndarray]] = {}
        self._models: dict[tuple[str, str], Template] = {}
        self.check_alignment_covers()

    # ------------------------------------------------------------------ index
    def instance_ids(self, category: str, split: str | None = None) -> list[str]:
        """Instance ids (file stems, e.g. ``airplane_0001``) of a category's split, sorted."""
        ids = sorted(_off_files(self.root / category / (split or self.split)))
        n = self.instances_per_category
        return ids[:n] if n and (split or self.split) == self.split else ids

    def instances(self) -> dict[str, list[str]]:
        return {c: self.instance_ids(c) for c in self.categories}

    def check_layout(self, name: str, report: LayoutReport) -> None:
        from catpose.resting import solid_hull

        present = {c: self.instance_ids(c) for c in self.categories}
        if not any(present.values()):
            report.problem(
                f"no {self.split}-split OFF files under {self.root}/<category>/{self.split}/ for {self.categories}: "
                "set dataset.root to the unpacked ModelNet40 folder (it holds airplane/, chair/, ...)"
            )
            return
        for c, ids in present.items():
            if not ids:
                report.problem(
                    f"{self.root / c / self.split} has no .off files: check dataset.categories and dataset.split"
                )
        if report.problems:
            return
        category, ids = next((c, ids) for c, ids in present.items() if ids)
        path = _off_files(self.root / category / self.split)[ids[0]]
        try:
            if solid_hull(read_mesh(path)[0]) is None:
                report.problem(
                    f"{path} is flat (no volume): ours has no resting pose for it; replace it with a solid mesh"
                )
        except CatposeError as e:
            report.problem(str(e))
        report.facts.append(f"{sum(map(len, present.values()))} {self.split}-split shapes in {len(present)} categories")
        check_templates(self, report, lambda c, inst: inst in self.instance_ids(c, self.template_split))

    # ------------------------------------------------------------------ shapes
    def _find(self, category: str, instance_id: str) -> tuple[Path, str]:
        for split in (self.split, self.template_split, "train", "test"):
            folder = self.root / category / split
            path = folder / f"{instance_id}.off"
            found = path if path.is_file() else _off_files(folder).get(instance_id)  # .OFF: from the listing
            if found is not None:
                return found, split
        raise DatasetError(
            f"no ModelNet40 file for {category}/{instance_id} under {self.root}/{category}/"
            f"{{train,test}}; check the instance id"
        )

    def canonical_mesh(self, category: str, instance_id: str) -> tuple[np.ndarray, np.ndarray]:
        """Vertices (V, 3) in the canonical object frame (z up, x forward, unit sphere) and triangles."""
        path, split = self._find(category, instance_id)
        key = (category, split, instance_id)
        if key not in self._meshes:
            v, f = read_mesh(path)
            v = apply_R(self.canonical_rotation(category, instance_id), v)
            try:
                v, _, _ = normalize_to_unit_sphere(v)
            except ValueError:
                raise DatasetError(f"{path} has zero extent") from None
            self._meshes[key] = (v, f)
        return self._meshes[key]

    def instance_model(self, category: str, instance_id: str) -> Template:
        key = (category, instance_id)
        if key not in self._models:
            v, f = self.canonical_mesh(category, instance_id)
            self._models[key] = sampled_template(
                v,
                f,
                f"modelnet40/{instance_id}",
                category,
                self.template_points,
                self.seed,
                self.symmetric.get(category),
            )
        return self._models[key]

    # ------------------------------------------------------------------ views
    def observation(self, obs_id: str) -> Observation:
        """Render view ``obs_id``: depth, Gaussian noise on the object's pixels, back-projection, then
        the kept points and their normals (:func:`~catpose.datasets.views.kept_view`)."""
        category, instance_id, view = self.parse(obs_id)
        v, f = self.canonical_mesh(category, instance_id)
        rng = np.random.default_rng(stable_seed(self.seed, "modelnet40", obs_id))
        T_camera_object = self.view.sample(rng)
        depth = render_depth(v, f, T_camera_object, self.camera)
        if self.view.depth_noise_std > 0:
            hit = depth > 0
            depth[hit] += rng.normal(0.0, self.view.depth_noise_std, size=int(hit.sum())).astype(depth.dtype)
        points, _ = depth_to_points(depth, self.camera)
        if len(points) < self.image.min_points:
            raise DatasetError(
                f"ModelNet40 {obs_id}: only {len(points)} pixels see the object; move the camera closer (distance) "
                "or enlarge the image"
            )
        points, normals = kept_view(points, self.view.max_points, self.image.normal_radius, rng)
        return view_observation(
            obs_id,
            points,
            normals,
            T_camera_object[:3, 2].copy(),
            T_camera_object,
            self.symmetric.get(category),
            {"view": view, "split": self.split, "aligned": self.aligned_instance(category, instance_id)},
            DepthImage(depth, self.camera.K, depth > 0),
        )
