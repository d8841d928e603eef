"""BOP's AR in the tables (``bench suite``, ``bench table``) equals ``bench score`` on the same runs.

A tiny cluttered set (a box as object 1 and a cylinder as object 4, two scenes, 160 x 120 pixels) in the BOP layout, one
ICP run on it, then the AR columns of the suite and of ``bench table`` against ``bench export`` +
``bench score`` of the same run directory.
"""

from __future__ import annotations

import json

import pytest
import trimesh

from catpose.bench.run.bop_ar import AR_KEYS


@pytest.fixture(scope="module")
def clutter_run(tmp_path_factory):
    """(run directory, tmp folder) of ``bench run method=icp dataset=clutter`` on a tiny set."""
    tmp = tmp_path_factory.mktemp("bop_ar")
    root = tmp / "bop"
    (root / "models").mkdir(parents=True)
    trimesh.creation.box(extents=[60.0, 40.0, 90.0]).export(root / "models" / "obj_000001.ply")
    trimesh.creation.cylinder(radius=30.0, height=80.0, sections=24).export(root / "models" / "obj_000004.ply")
    (root / "models" / "models_info.json").write_text(
        json.dumps(
            {
                "1": {"diameter": 118.0},
                "4": {"diameter": 110.0, "symmetries_continuous": [{"axis": [0, 0, 1], "offset": [0, 0, 0]}]},
            }
        )
    )
    mp = pytest.MonkeyPatch()
    mp.setenv("CATPOSE_CACHE_DIR", str(tmp / "cache"))  # the errors' cache, not the user's
    from catpose.bench.run.config import compose
    from catpose.bench.run.runner import run

    overrides = [
        "method=icp",
        "method.num_starts=2",
        "dataset=clutter",
        f"dataset.root={root}",
        f"dataset.cache_dir={tmp / 'clutter'}",
        "dataset.num_scenes=2",
        "dataset.obj_ids=[1,4]",  # categories (can, can) from the config; 4 symmetric by models_info
        "dataset.objects_per_scene=[2,2]",
        "dataset.width=160",
        "dataset.height=120",
        "dataset.K=[[300.0,0,79.5],[0,300.0,59.5],[0,0,1]]",
        "dataset.distance_mm=[500.0,600.0]",
        "dataset.min_visible_pixels=20",
        "dataset.min_visib_fract=0.0",
        f"output_root={tmp / 'out'}",
        "progress=false",
        "print_summary=false",
    ]
    run_dir = run(compose(overrides), overrides)
    yield run_dir, tmp
    mp.undo()


def _scored(run_dir, tmp) -> dict[str, float]:
    """AR and its parts by ``bench export`` and ``bench score`` (their bop_errors.jsonl)."""
    from catpose.bench.cli import main
    from catpose.bench.scoring.bop_eval import metric_value, read_errors

    csv = tmp / "icp_clutter-test.csv"
    assert main(["export", str(run_dir), "--out", str(csv)]) == 0
    assert main(["score", str(csv), "--gt", str(run_dir), "--out", str(tmp / "scored"), "--force"]) == 0
    errors, _ = read_errors(tmp / "scored" / "bop_errors.jsonl")
    return {k: metric_value(errors, k) for k in AR_KEYS}


def test_table_and_suite_ar_equal_bench_score(clutter_run) -> None:
    from catpose.bench.real.suite import with_ar
    from catpose.bench.real.suite_table import format_table
    from catpose.bench.report.runs import load_runs
    from catpose.bench.report.tables import build_table
    from catpose.bench.run.bop_ar import ar_scores, target_errors

    run_dir, tmp = clutter_run
    expected = _scored(run_dir, tmp)
    assert all(0.0 <= v <= 1.0 for v in expected.values()), expected
    errors = target_errors(run_dir)
    assert len(errors) == len(json.loads(json.dumps(list(errors["sample_id"]))))  # one row per target
    assert ar_scores(errors) == pytest.approx(expected, abs=1e-12)
    assert target_errors(run_dir) is not None  # the cached entry reads back the same figures
    assert ar_scores(target_errors(run_dir)) == pytest.approx(expected, abs=1e-12)

    # bench suite: the pooled row and its AR column
    row = with_ar({"mean_err_deg": 1.0, "median_err_deg": 1.0, "acc10": 1.0, "acc30": 1.0}, errors)
    assert {k: row[k] for k in AR_KEYS} == pytest.approx(expected, abs=1e-12)
    text = format_table(
        {("clutter", "icp"): dict(row, median_runtime_s=0.1, n=len(errors), failed=0)}, ["clutter"], ["icp"], {}
    )
    assert "clutter: AR (VSD / MSSD / MSPD)" in text
    assert f"**{expected['ar']:.3f}** ({expected['ar_vsd']:.3f} / {expected['ar_mssd']:.3f}" in text

    # bench suite --objects: per object, the AR of bench score's per-object rows
    from catpose.bench.real.split import load_split
    from catpose.bench.real.suite_table import object_rows
    from catpose.bench.scoring.bop_eval import read_errors, score_table

    scored, _ = read_errors(tmp / "scored" / "bop_errors.jsonl")
    by_object = score_table(scored, ["ar"], ["object"])
    rows = object_rows({"icp": run_dir}, load_split("clutter"), "dev")  # scenes 0 and 1 are dev scenes
    assert [r["ar"] for r in rows] == pytest.approx(list(by_object[by_object["group"] == "object"]["ar"]), abs=1e-12)

    # bench table: AR columns after the layout's own metrics, the "all" column equal to bench score
    runs, _ = load_runs([str(run_dir)])
    table = build_table(runs)
    values = {m: v for (r, c), (v, m) in table.cells.items() if c[0] == "All" and m in AR_KEYS}
    assert values == pytest.approx(expected, abs=1e-12)
    assert [c[-1] for c in table.columns][-4:] == ["AR ↑", "AR_VSD ↑", "AR_MSSD ↑", "AR_MSPD ↑"]


def test_tables_without_bop_data_have_no_ar_columns(tmp_path) -> None:
    from catpose.bench.run.bop_ar import target_errors
    from catpose.bench.run.config import compose
    from catpose.bench.run.runner import run

    overrides = ["method=icp", "method.num_starts=1", "dataset=synthetic", "limit=1", f"output_root={tmp_path}"]
    run_dir = run(compose(overrides + ["progress=false", "print_summary=false"]), overrides)
    assert target_errors(run_dir) is None
    from catpose.bench.report.runs import load_runs
    from catpose.bench.report.tables import build_table

    table = build_table(load_runs([str(run_dir)])[0])
    assert not any(m in AR_KEYS for (_, _), (_, m) in table.cells.items())
