"""Golden inputs: a regression suite's problems frozen in one ``.npz`` file.

The problems are rendered once (``bench regress --write-inputs``), stored as float32 and read back
as float64, so every machine judges the code on the same bits (a CPU's BLAS kernel cannot change
the inputs). Layout: ``meta``, a JSON string (suite, dataset overrides, one record per sample:
ids, category, template id, symmetries, info); per sample ``i``: ``p{i}``, ``n{i}`` (N, 3) points
and normals (camera frame), ``g{i}`` (3,) ground normal, ``T{i}`` (4, 4) ``T_template_camera``, and
with a depth image ``d{i}`` (H, W), ``k{i}`` (3, 3) intrinsics, ``m{i}`` (H, W) mask; per template
``j``: ``tp{j}``, ``tn{j}`` (M, 3) (template frame), ``tu{j}`` (3,) up axis, with a mesh ``tv{j}``
(V, 3) and ``tf{j}`` (F, 3) int32. Units are the dataset's (object-normalised)."""

from __future__ import annotations

import json
import zipfile
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from catpose.errors import ConfigError, DatasetError
from catpose.types import DepthImage, GroundTruth, RegistrationProblem, Sample, Template

FORMAT_VERSION = 1


def _f32(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=np.float64).astype(np.float32))


def write_golden(path: Path, suite: str, overrides: Sequence[str], samples: Sequence[Sample]) -> Path:
    """Freeze ``samples`` (their problems and ground truth) into ``path`` (see the module doc)."""
    arrays: dict[str, np.ndarray] = {}
    templates: dict[str, int] = {}
    records = []
    for i, s in enumerate(samples):
        tpl = s.problem.template
        if tpl.template_id not in templates:
            j = templates[tpl.template_id] = len(templates)
            arrays[f"tp{j}"], arrays[f"tn{j}"], arrays[f"tu{j}"] = _f32(tpl.points), _f32(tpl.normals), _f32(tpl.up)
            if tpl.has_mesh:
                arrays[f"tv{j}"] = _f32(tpl.vertices)
                arrays[f"tf{j}"] = np.asarray(tpl.triangles, dtype=np.int32)
        arrays[f"p{i}"] = _f32(s.problem.points_camera)
        arrays[f"n{i}"] = _f32(s.problem.normals_camera)
        arrays[f"g{i}"] = _f32(s.problem.ground_normal_camera)
        arrays[f"T{i}"] = np.asarray(s.gt.T_template_camera, dtype=np.float64)
        if s.problem.depth_image is not None:
            di = s.problem.depth_image
            arrays[f"d{i}"], arrays[f"k{i}"], arrays[f"m{i}"] = _f32(di.depth), np.asarray(di.K, float), di.mask
        axis = s.gt.symmetry_axis
        records.append(
            {
                "sample_id": s.problem.sample_id,
                "category": s.problem.category,
                "group_id": s.group_id,
                "template_id": tpl.template_id,
                "template_index": templates[tpl.template_id],
                "template_category": tpl.category,
                "template_symmetry_axis": None
                if tpl.symmetry_axis is None
                else np.asarray(tpl.symmetry_axis, float).tolist(),
                "symmetry_axis": None if axis is None else np.asarray(axis, float).tolist(),
                "symmetries": [np.asarray(S, float).reshape(-1).tolist() for S in s.gt.symmetries],
                "info": {
                    str(k): v for k, v in dict(s.info).items() if isinstance(v, (str, int, float, bool, type(None)))
                },
            }
        )
    meta = {"format": FORMAT_VERSION, "suite": suite, "overrides": list(overrides), "samples": records}
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from catpose import atomic

    with atomic.atomic_path(path) as tmp:
        np.savez_compressed(tmp, meta=np.array(json.dumps(meta)), **arrays)
    return path


def read_golden(path: Path) -> tuple[Sample, ...]:
    """The problems of a golden file written by :func:`write_golden`, loaded as float64 (identical
    bits on every machine).

    Raises :class:`ConfigError` naming the file when it is missing or of another format.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"golden inputs {path} do not exist; write them with `bench regress --write-inputs`")
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in z.files if k != "meta"}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as e:  # a cut-off file: one line
        raise ConfigError(
            f"golden inputs {path} cannot be read ({e}); rewrite them with `bench regress --write-inputs`"
        ) from None
    if meta.get("format") != FORMAT_VERSION:
        raise ConfigError(
            f"golden inputs {path} have format {meta.get('format')}, this code reads "
            f"{FORMAT_VERSION}; rewrite them with `bench regress --write-inputs`"
        )
    f64 = lambda a: np.asarray(a, dtype=np.float64)  # noqa: E731
    templates: dict[int, Template] = {}
    samples = []
    for i, r in enumerate(meta["samples"]):
        j = int(r["template_index"])
        if j not in templates:
            tax = r.get("template_symmetry_axis")
            mesh = (f64(arrays[f"tv{j}"]), arrays[f"tf{j}"].astype(np.int64)) if f"tv{j}" in arrays else (None, None)
            templates[j] = Template(
                template_id=r["template_id"],
                category=r["template_category"],
                points=f64(arrays[f"tp{j}"]),
                normals=f64(arrays[f"tn{j}"]),
                vertices=mesh[0],
                triangles=mesh[1],
                up=f64(arrays[f"tu{j}"]),
                symmetry_axis=None if tax is None else f64(tax),
            )
        problem = RegistrationProblem(
            sample_id=r["sample_id"],
            category=r["category"],
            points_camera=f64(arrays[f"p{i}"]),
            normals_camera=f64(arrays[f"n{i}"]),
            ground_normal_camera=f64(arrays[f"g{i}"]),
            template=templates[j],
            depth_image=DepthImage(f64(arrays[f"d{i}"]), arrays[f"k{i}"], arrays[f"m{i}"])
            if f"d{i}" in arrays
            else None,
        )
        axis = r.get("symmetry_axis")
        gt = GroundTruth(
            T_template_camera=f64(arrays[f"T{i}"]),
            symmetry_axis=None if axis is None else f64(axis),
            symmetries=tuple(f64(S).reshape(4, 4) for S in r.get("symmetries") or ()),
        )
        samples.append(
            Sample(problem=problem, gt=gt, group_id=r.get("group_id") or r["sample_id"], info=dict(r.get("info") or {}))
        )
    return tuple(samples)


def perturbed(sample: Sample, rel: float, seed: int) -> Sample:
    """``sample`` with every input coordinate scaled by ``1 + rel * u``, ``u ~ N(0, 1)`` drawn per
    coordinate from ``seed``: the relative perturbation used to find chaotic samples (a change
    of the last bits of the input, far below any sensor's noise)."""
    rng, rng_extra = np.random.default_rng(seed), np.random.default_rng([seed, 1])  # meshes, depth: their own stream

    def jitter(a, rng=rng):
        return np.asarray(a, float) * (1.0 + rel * rng.standard_normal(np.shape(a)))

    p = sample.problem
    vertices = None if p.template.vertices is None else jitter(p.template.vertices, rng_extra)
    tpl = replace(p.template, points=jitter(p.template.points), vertices=vertices)
    di = p.depth_image
    depth_image = None if di is None else DepthImage(jitter(di.depth, rng_extra), di.K, di.mask)
    problem = replace(p, points_camera=jitter(p.points_camera), template=tpl, depth_image=depth_image)
    return replace(sample, problem=problem)


class GoldenProtocol:
    """Serves golden samples (:func:`read_golden`) to the runner's per-sample function as both its
    protocol (``load(dataset, sample_id)``, the dataset argument ignored) and its dataset (only
    ``category_of``)."""

    name = "golden"

    def __init__(self, golden: Sequence[Sample], transform=None) -> None:
        self._samples = {s.problem.sample_id: s for s in golden}
        self._transform = transform

    def sample_ids(self, dataset=None) -> list[str]:
        return list(self._samples)

    def category_of(self, sample_id: str) -> str | None:
        s = self._samples.get(sample_id)
        return None if s is None else s.problem.category

    def load(self, dataset, sample_id: str) -> Sample:
        if sample_id not in self._samples:
            raise DatasetError(f"golden inputs have no sample {sample_id!r}")
        s = self._samples[sample_id]
        return self._transform(s) if self._transform else s
