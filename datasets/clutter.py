"""``dataset=clutter``: cluttered synthetic scenes of real object meshes, in the BOP layout.

Several of the real YCB-Video models (``<root>/models``, e.g. ``../shared/data/bop/ycbv/models``:
mm PLY meshes and ``models_info.json``) lie on a table in random stable resting poses (upright,
on a side, upside down: :mod:`catpose.datasets.clutter_layout`), hide each other, and are seen
by a depth camera with the Kinect or RealSense sensor model (``sensor``,
:mod:`catpose.datasets.sensor`); each object's visible mask, visible fraction and ground-truth
pose are written beside the depth image (:mod:`catpose.datasets.clutter_render`). The files are
the BOP layout, so the frames are read by the BOP loader (:class:`~catpose.datasets.bop.BOP`) like
the real YCB-Video frames: object pixels from ``mask_visib``, the ground normal from a plane fit
to the background, instances less than ``min_visib_fract`` visible left out (BOP19).

The scenes are generated when their ids are first listed, deterministically from ``scene_seed`` and the scene id,
into a cache folder outside the repository: ``cache_dir`` (default ``$CATPOSE_CACHE_DIR`` or
``~/.cache/catpose``) ``/clutter/clutter-<hash>`` where the hash covers every generation setting
and the model files, so a changed setting gets its own folder. Only the scenes a run loads
(``scenes``; default all ``num_scenes``) are generated; ``bench clutter`` generates ahead and
prints the folder. Which scenes choose defaults and which report results is fixed in
``configs/split/clutter.yaml`` (docs/choosing-defaults.md).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np

from catpose import disk_cache
from catpose.datasets.bop import BOP
from catpose.datasets.clutter_layout import ClutterSpec, layout_scene
from catpose.datasets.clutter_render import render_scene, write_scene
from catpose.datasets.meshio import read_mesh
from catpose.datasets.templates import TemplateOptions
from catpose.errors import ConfigError, DatasetError

#: bumped whenever generated files change for the same settings
GENERATOR_VERSION = "2"

#: the YCB-Video categories (BOP obj_id -> category), as configs/dataset/ycbv.yaml
YCBV_CATEGORIES = {1: "can", 4: "can", 5: "bottle", 6: "can", 9: "can", 12: "bottle", 13: "bowl", 14: "mug"}


def _model_files(models_root: Path, obj_ids: Sequence[int]) -> list[Path]:
    files = [models_root / f"obj_{o:06d}.ply" for o in obj_ids] + [models_root / "models_info.json"]
    missing = [str(f) for f in files if not f.is_file()]
    if missing:
        raise ConfigError(
            f"dataset.root: {models_root} lacks {missing[0]}"
            + (f" and {len(missing) - 1} more" if len(missing) > 1 else "")
            + "; set dataset.root to a BOP dataset whose models/ has obj_XXXXXX.ply and models_info.json"
        )
    return files


def clutter_root(spec: ClutterSpec, models_root: Path, cache_dir: Path | None = None) -> Path:
    """The cache folder of ``spec`` made from the models in ``models_root``."""
    h = hashlib.blake2b(digest_size=8)
    h.update(json.dumps({"version": GENERATOR_VERSION, **asdict(spec)}, sort_keys=True).encode())
    for f in _model_files(models_root, spec.obj_ids):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return (cache_dir or disk_cache.cache_dir()) / "clutter" / f"clutter-{h.hexdigest()}"


def scene_ids(spec: ClutterSpec, scenes: Sequence[int] | None) -> list[int]:
    """The scene ids ``scenes`` (None: all ``spec.num_scenes``), each checked to be one of the set's."""
    wanted = list(range(spec.num_scenes)) if scenes is None else [int(s) for s in scenes]
    bad = [s for s in wanted if not 0 <= s < spec.num_scenes]
    if bad:
        raise ConfigError(f"dataset.scenes lists {bad[:5]}, outside 0..{spec.num_scenes - 1} (dataset.num_scenes)")
    return wanted


def scene_done(root: Path, scene_id: int) -> bool:
    return (root / "test" / f"{scene_id:06d}" / "scene_camera.json").is_file()


def prepare_root(spec: ClutterSpec, models_root: Path, root: Path) -> None:
    """Create ``root`` with its ``models/`` (copies of the models and ``models_info.json``) and
    ``spec.json`` (the settings that made it)."""
    (root / "models").mkdir(parents=True, exist_ok=True)
    for f in _model_files(models_root, spec.obj_ids):
        if not (root / "models" / f.name).is_file():
            tmp = root / "models" / f".{f.name}.{os.getpid()}"
            shutil.copyfile(f, tmp)
            os.replace(tmp, root / "models" / f.name)
    if not (root / "spec.json").is_file():
        (root / "spec.json").write_text(json.dumps({"version": GENERATOR_VERSION, **asdict(spec)}, indent=1))


def symmetry_axes(models_root: Path, obj_ids: Sequence[int]) -> dict[int, np.ndarray | None]:
    """obj_id -> the first continuous symmetry axis of ``models_info.json`` (model frame), or None."""
    info = json.loads((Path(models_root) / "models_info.json").read_text())
    out: dict[int, np.ndarray | None] = {}
    for o in obj_ids:
        sym = (info.get(str(o)) or {}).get("symmetries_continuous") or []
        out[int(o)] = np.asarray(sym[0]["axis"], dtype=np.float64) if sym else None
    return out


def generate(
    spec: ClutterSpec,
    models_root: str | Path,
    scenes: Sequence[int] | None = None,
    cache_dir: str | Path | None = None,
    log=None,
) -> Path:
    """Write the scenes ``scenes`` (default all) of ``spec`` made from the models in
    ``models_root`` that are not there yet; returns the set's root (:func:`clutter_root`)."""
    from catpose.raycast import RayCaster
    from catpose.resting import resting_ups

    models_root = Path(models_root)
    root = clutter_root(spec, models_root, Path(cache_dir) if cache_dir else None)
    wanted = scene_ids(spec, scenes)
    todo = [s for s in wanted if not scene_done(root, s)]
    prepare_root(spec, models_root, root)
    if not todo:
        return root
    meshes = {o: read_mesh(models_root / f"obj_{o:06d}.ply") for o in spec.obj_ids}
    casters = {o: RayCaster(v, f) for o, (v, f) in meshes.items()}
    rests = {o: resting_ups(v) for o, (v, _) in meshes.items()}
    axes = symmetry_axes(models_root, spec.obj_ids)
    split_dir = root / "test"
    split_dir.mkdir(parents=True, exist_ok=True)
    log = log or logging.getLogger(__name__).info
    log(f"clutter: generating {len(todo)} scenes into {root}")
    for i, s in enumerate(todo):
        layout = layout_scene(spec, s, {o: v for o, (v, _) in meshes.items()}, rests, axes)
        write_scene(split_dir, spec, layout, render_scene(spec, layout, casters))
        if (i + 1) % 20 == 0:
            log(f"clutter: {i + 1}/{len(todo)} scenes")
    return root


class Clutter(BOP):
    """Cluttered synthetic scenes of real models (see the module docstring), read as BOP frames.

    Args:
        root: a BOP dataset folder whose ``models/`` holds the meshes (``obj_XXXXXX.ply`` in mm,
            ``models_info.json``), e.g. ``../shared/data/bop/ycbv``; nothing else of it is read.
        cache_dir: where the generated sets live (None: ``$CATPOSE_CACHE_DIR`` or ``~/.cache/catpose``).
        spec: the generation settings (:class:`~catpose.datasets.clutter_layout.ClutterSpec`; the
            config gives its fields as flat keys).
        mask_noise: the loaded masks corrupted as a segmenter's are, strength drawn per instance
            up to this (:mod:`catpose.datasets.mask_noise`; 0: the written masks), seeded by the run.
        scenes: the scene ids loaded (and generated if missing); None: all.
        generate_missing: generate missing scenes when the ids are first listed (false: a missing
            scene is a DatasetError).
        Every other argument is the BOP loader's (:class:`~catpose.datasets.bop.BOP`).
    """

    name = "clutter"

    def __init__(
        self,
        root: str,
        cache_dir: str | None = None,
        spec: ClutterSpec = ClutterSpec(),
        mask_noise: float = 0.0,
        scenes: list[int] | None = None,
        generate_missing: bool = True,
        categories: dict[int | str, str] | None = None,
        template: TemplateOptions = TemplateOptions(),
        mask: str = "mask_visib",
        min_visible_pixels: int = 50,
        plane_distance_mm: float = 10.0,
        plane_iterations: int = 1000,
        plane_max_points: int = 20000,
        normal_radius: float = 0.1,
        max_points: int = 2048,
        seed: int = 0,
        min_visib_fract: float = 0.1,
    ) -> None:
        self.spec = spec
        self.models_root = Path(root) / "models"
        self.cache_dir = Path(cache_dir) if cache_dir else None
        self.generate_missing = bool(generate_missing)
        cache_root = clutter_root(spec, self.models_root, self.cache_dir)
        self.wanted_scenes = scene_ids(spec, scenes)
        prepare_root(spec, self.models_root, cache_root)
        super().__init__(
            root=str(cache_root),
            split="test",
            scenes=self.wanted_scenes,
            categories=YCBV_CATEGORIES if categories is None else categories,
            template=template,
            mask=mask,
            min_visible_pixels=min_visible_pixels,
            plane_distance_mm=plane_distance_mm,
            plane_iterations=plane_iterations,
            plane_max_points=plane_max_points,
            normal_radius=normal_radius,
            max_points=max_points,
            seed=seed,
            min_visib_fract=min_visib_fract,
            targets=None,
            mask_noise=mask_noise,
        )

    def observation_ids(self) -> list[str]:
        """The ids of the loaded scenes' instances; missing scenes are generated first."""
        if self._ids is None:
            missing = [s for s in self.wanted_scenes if not scene_done(self.root, s)]
            if missing and not self.generate_missing:
                raise DatasetError(
                    f"clutter scenes {missing[:5]} are not generated under {self.root}; run "
                    "`bench clutter` or set dataset.generate_missing=true"
                )
            if missing:
                generate(self.spec, self.models_root, missing, self.cache_dir)
        return super().observation_ids()
