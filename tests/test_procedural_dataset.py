"""``dataset=procedural``: composed and built like every dataset, its root written once into the
cache (whole or not at all) and reused, every observation loads, and it gives the same observations
as ``modelnet40_resampled`` reading the root that ``python -m catpose.datasets.procedural`` writes."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from catpose.datasets.procedural import Procedural, ProceduralSpec, build_root, main, procedural_root
from catpose.datasets.templates import TemplateOptions
from catpose.datasets.views import ViewOptions
from catpose.errors import ConfigError, DatasetError


@pytest.fixture()
def cache(tmp_path) -> Path:
    return tmp_path / "cache"


def test_the_config_composes_and_builds_the_dataset(cache):
    from hydra import compose, initialize_config_module

    from catpose.bench.run.build import build_from_config

    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose(
            "run",
            overrides=[
                "dataset=procedural",
                "dataset.count=3",
                f"dataset.cache_dir={cache}",
                "dataset.views_per_instance=1",
            ],
        )
    name, ds = build_from_config(cfg.dataset, "dataset")
    assert name == "procedural" and isinstance(ds, Procedural)
    assert ds.observation_ids() == ["chair/chair_8000/v00", "chair/chair_8001/v00", "chair/chair_8002/v00"]
    assert ds.root == procedural_root(ds.spec, cache)


def test_every_observation_loads_and_views_are_deterministic(cache):
    def airplanes(seed: int = 0) -> Procedural:
        return Procedural(
            category="airplane",
            count=2,
            views_per_instance=1,
            view=ViewOptions(max_points=500),
            cache_dir=str(cache),
            seed=seed,
        )

    ds, again = airplanes(), airplanes()
    assert ds.observation_ids() == ["airplane/airplane_8000/v00", "airplane/airplane_8001/v00"]
    for obs_id in ds.observation_ids():
        obs = ds.observation(obs_id)
        assert obs.points_camera.shape == (500, 3) and np.isfinite(obs.points_camera).all()
        np.testing.assert_array_equal(obs.points_camera, again.observation(obs_id).points_camera)
    other = airplanes(seed=1).observation("airplane/airplane_8000/v00").points_camera
    assert not np.array_equal(ds.observation("airplane/airplane_8000/v00").points_camera, other)
    (template,) = ds.category_templates("airplane")  # the first drawn shape by default
    assert len(template.points) == 2048


def test_a_root_is_written_once_and_reused(cache):
    spec = ProceduralSpec(category="chair", count=2, shape_seed=0)
    root = build_root(cache / "r", spec)
    stamp = (root / "chair" / "chair_8000.txt").stat().st_mtime_ns
    assert json.loads((root / "spec.json").read_text())["count"] == 2
    assert build_root(cache / "r", spec) == root  # kept: nothing rewritten
    assert (root / "chair" / "chair_8000.txt").stat().st_mtime_ns == stamp
    with pytest.raises(DatasetError, match="does not hold this procedural set"):
        build_root(cache / "r", ProceduralSpec(category="chair", count=3, shape_seed=0))
    (cache / "foreign").mkdir()
    (cache / "foreign" / "notes.txt").write_text("not ours")
    with pytest.raises(DatasetError, match="spec.json"):
        build_root(cache / "foreign", spec)
    assert (cache / "foreign" / "notes.txt").read_text() == "not ours"
    assert not [p for p in cache.iterdir() if p.name.startswith(".")]  # no building folder left behind


def test_a_set_is_one_blas_kernels_bits(cache, monkeypatch):
    """The kernel moves a few points' last digit, so it is part of the spec: another kernel's set
    gets its own cache folder, and a named root written under one kernel is not taken for another's."""
    import catpose.datasets.procedural as procedural

    spec = ProceduralSpec(category="chair", count=1, shape_seed=0)
    root = build_root(cache / "r", spec)
    here = procedural_root(spec, cache)
    monkeypatch.setattr(procedural, "blas_kernel", lambda: "openblas:Elsewhere")
    assert procedural_root(spec, cache) != here
    with pytest.raises(DatasetError, match="does not hold this procedural set"):
        build_root(root, spec)


def test_a_failed_build_leaves_nothing(cache, monkeypatch):
    import catpose.datasets.procedural as procedural

    def broken(category, rng):
        raise RuntimeError("generator broke")

    monkeypatch.setattr(procedural, "draw", broken)
    with pytest.raises(RuntimeError, match="generator broke"):
        build_root(cache / "r", ProceduralSpec(category="chair", count=1, shape_seed=0))
    assert not (cache / "r").exists() and not list(cache.iterdir())


def test_the_dataset_is_the_resampled_loader_on_the_written_root(tmp_path, cache):
    """The experiments' roots (written outside a run, read by dataset=modelnet40_resampled) and
    dataset=procedural give the same views of the same shapes, linked templates included."""
    from catpose.datasets.modelnet40_resampled import RESAMPLED_FRAME, ModelNet40Resampled

    shared = tmp_path / "shared"
    build_root(tmp_path / "planes", ProceduralSpec(category="chair", count=1, shape_seed=7))
    (shared / "chair").mkdir(parents=True)
    (tmp_path / "planes" / "chair" / "chair_8000.txt").rename(shared / "chair" / "chair_0391.txt")
    args = ["--category", "chair", "--count", "2", "--template-root", str(shared), "--template-ids", "chair_0391"]
    assert main([str(tmp_path / "root"), *args]) == 0
    by_path = ModelNet40Resampled(
        str(tmp_path / "root"),
        categories=["chair"],
        split="train",
        views_per_instance=1,
        template=TemplateOptions(templates={"chair": ["chair_0391"]}),
        frame=replace(RESAMPLED_FRAME, alignment_table=str(tmp_path / "root" / "alignment_chair.csv")),
    )
    ds = Procedural(
        category="chair",
        count=2,
        template=TemplateOptions(templates={"chair": ["chair_0391"]}),
        template_root=str(shared),
        views_per_instance=1,
        cache_dir=str(cache),
    )
    assert ds.observation_ids() == by_path.observation_ids()
    for obs_id in ds.observation_ids():
        np.testing.assert_array_equal(ds.observation(obs_id).points_camera, by_path.observation(obs_id).points_camera)
    (a,), (b,) = ds.category_templates("chair"), by_path.category_templates("chair")
    np.testing.assert_array_equal(a.points, b.points)
    for name in ("chair/chair_8000.txt", "modelnet40_train.txt", "alignment_chair.csv"):
        assert (ds.root / name).read_bytes() == (tmp_path / "root" / name).read_bytes()


def test_bad_settings_are_one_line_errors(tmp_path, cache, capsys):
    with pytest.raises(ConfigError, match="dataset.category"):
        Procedural(category="car", cache_dir=str(cache))
    with pytest.raises(ConfigError, match="dataset.count"):
        Procedural(count=0, cache_dir=str(cache))
    with pytest.raises(ConfigError, match="dataset.template_root"):
        Procedural(template=TemplateOptions(templates={"chair": ["chair_0391"]}), count=1, cache_dir=str(cache))
    with pytest.raises(DatasetError, match="does not exist"):
        Procedural(
            template=TemplateOptions(templates={"chair": ["chair_0391"]}),
            template_root=str(tmp_path),
            count=1,
            cache_dir=str(cache),
        )
    assert main([str(tmp_path / "r"), "--category", "chair", "--count", "0"]) == 2
    assert "error: dataset.count" in capsys.readouterr().err
