"""Category-level protocols refuse datasets whose instance frames are not declared consistent."""

from __future__ import annotations

from pathlib import Path

import pytest

from catpose.bench.protocols.absolute import GtModel, Templates
from catpose.bench.protocols.relative import Relative
from catpose.datasets.modelnet40 import ModelNet40, ShapeFrame
from catpose.datasets.templates import TemplateOptions
from catpose.errors import ConfigError


def _box_off(path: Path, dims: tuple[float, float, float]) -> None:
    import trimesh

    m = trimesh.creation.box(extents=dims)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        "\n".join(
            [f"OFF\n{len(m.vertices)} {len(m.faces)} 0"]
            + [" ".join(map(str, v)) for v in m.vertices]
            + [f"3 {a} {b} {c}" for a, b, c in m.faces]
        )
        + "\n"
    )


@pytest.fixture()
def root(tmp_path: Path) -> Path:
    _box_off(tmp_path / "box/train/box_0001.off", (2.0, 1.0, 0.5))
    _box_off(tmp_path / "box/train/box_0002.off", (1.0, 2.0, 0.5))  # the same box, yawed 90 deg
    return tmp_path


def _dataset(root: Path, **kw) -> ModelNet40:
    ds = ModelNet40(
        str(root),
        categories=["box"],
        split="train",
        views_per_instance=1,
        template=TemplateOptions(templates={"box": ["box_0001"]}, template_points=200),
        frame=ShapeFrame(**kw),
    )
    ds.name = "modelnet40"
    return ds


@pytest.mark.parametrize("protocol", [Templates(), Relative(template_source="category")])
def test_raw_modelnet_is_refused_with_the_fix_in_one_line(root, protocol):
    ds = _dataset(root)
    assert ds.frames_consistent is False
    with pytest.raises(ConfigError) as e:
        protocol.sample_ids(ds)
    msg = str(e.value)
    assert "\n" not in msg and "modelnet40_aligned" in msg and "align.py" in msg
    assert "dataset.alignment_table" in msg
    with pytest.raises(ConfigError):
        protocol.load(ds, "box/box_0002/v00|0")


def test_gt_model_and_own_template_relative_are_unaffected(root):
    ds = _dataset(root)
    for protocol in (GtModel(), Relative(template_source="own")):
        ids = protocol.sample_ids(ds)
        assert ids == ["box/box_0001/v00", "box/box_0002/v00"]
        assert protocol.load(ds, ids[1]).problem.points_camera.shape[1] == 3


def test_aligned_release_or_an_alignment_table_declares_frames_consistent(root, tmp_path):
    assert _dataset(root, aligned=True).frames_consistent
    table = tmp_path / "t.csv"
    table.write_text("category,instance_id,yaw_deg\nbox,box_0001,0\nbox,box_0002,90\n")  # every instance in use
    ds = _dataset(root, alignment_table=str(table))
    assert ds.frames_consistent
    assert Templates().sample_ids(ds) == ["box/box_0001/v00|0", "box/box_0002/v00|0"]
    assert Relative(template_source="category").sample_ids(ds) == Templates().sample_ids(ds)


def test_other_datasets_declare_consistent_frames():
    from catpose.datasets.synthetic import SyntheticDataset

    ds = SyntheticDataset(categories=["mug"], instances_per_category=1, views_per_instance=1)
    assert ds.frames_consistent and Templates().sample_ids(ds)


def test_bench_run_stops_with_one_line(root, tmp_path, capsys):
    from catpose.bench.run.command import main

    with pytest.raises(SystemExit) as e:
        main(
            [
                "method=icp",
                "dataset=modelnet40",
                f"dataset.root={root}",
                "dataset.categories=[box]",
                "protocol=templates",
                f"output_root={tmp_path / 'out'}",
                "progress=false",
            ]
        )
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "modelnet40_aligned" in err[0]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").rglob("samples.jsonl"))


def test_aligned_preset_composes():
    from hydra import compose, initialize_config_module

    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose("run", overrides=["dataset=modelnet40_aligned", "dataset.root=/x"])
    assert cfg.dataset.name == "modelnet40_aligned" and cfg.dataset.aligned is True
    assert cfg.dataset._target_ == "catpose.datasets.modelnet40.ModelNet40"
