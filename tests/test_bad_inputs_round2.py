"""Issue 42, "files and numbers you can trust, round 2": one test per numbered case, named after it.

Cases 16, 29, 35 and 36 (``catpose.register``) and 19 (FGR/RANSAC/TEASER with observation =
template) are tested beside the API and the methods. The output rule over every command is
``tests/test_output_rule.py``; the readers' property tests are ``tests/test_readers_property.py``.
Each case runs on toy runs and files made here (no shared data), in-process, in about a second.
"""

from __future__ import annotations

import errno
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from catpose import atomic
from catpose.bench.cli import main as bench
from catpose.bench.run.rundir import read_rows
from catpose.errors import ConfigError, DatasetError, InvalidInputError

TESTS = Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))

from _trust import CFG, one_error_line, rows, with_bop_ids, write_run  # noqa: E402

ROT = "1 0 0 0 1 0 0 0 1"
BOP_HEAD = "scene_id,im_id,obj_id,score,R,t,time"
TEMPLATES_CFG = dict(CFG, protocol={"name": "templates", "_target_": "catpose.bench.protocols.absolute.Templates"})


@pytest.fixture(autouse=True)
def _tests_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))


def per_sample_csv(path: Path, run_rows: list[dict], inverse: bool = False) -> Path:
    """The estimates of ``run_rows`` as a per-sample CSV (``T_camera_template`` with ``inverse``)."""
    lines = ["sample_id,R,t"]
    for r in run_rows:
        T = np.asarray(r["T_est"]).reshape(4, 4)
        T = np.linalg.inv(T) if inverse else T
        lines.append(f"{r['sample_id']},{' '.join(map(str, T[:3, :3].ravel()))},{' '.join(map(str, T[:3, 3]))}")
    path.write_text("\n".join(lines) + "\n")
    return path


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def templates_rows(n_views: int, k: int, present: int) -> list[dict]:
    """Rows of a templates run: ``n_views`` views, each registered to ``present`` of its ``k``
    templates (its estimates checked on all ``k``: ``info.cross_costs``)."""
    out = []
    for v in range(n_views):
        for t in range(present):
            r = rows([5.0 + t])[0]
            r.update(
                sample_id=f"mug/i{v}/v0|{t}",
                group_id=f"mug/i{v}/v0",
                obs_id=f"mug/i{v}/v0",
                instance_id=f"i{v}",
                protocol="templates",
                template_id=f"t{t}",
                info={"cross_costs": [0.1] * k},
            )
            out.append(r)
    return out


# ---------------------------------------------------------------------------------------------
# data loss (must refuse)


def test_case_01_score_out_containing_the_gt_run_is_refused(tmp_path, capsys):
    gt = write_run(tmp_path / "OUT/synthetic-gt_model/icp/seed0-default-1a2b3c4d", rows([5.0, 10.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0, 9.0]))
    before = snapshot(tmp_path / "OUT")
    for out in (tmp_path / "OUT/synthetic-gt_model/icp", tmp_path / "OUT"):
        assert bench(["score", str(preds), "--gt", str(gt), "--method", "m", "--out", str(out), "--force"]) == 2
        assert "contains the --gt run" in one_error_line(capsys, "score")
    assert snapshot(tmp_path / "OUT") == before


def test_case_02_export_never_replaces_a_file_without_force_nor_names_another_dataset(tmp_path, capsys):
    run = write_run(tmp_path / "run", with_bop_ids(rows([5.0, 10.0])), CFG)
    existing = tmp_path / "m_toy-test.csv"
    existing.write_text("mine\n")
    assert bench(["export", str(run), "--out", str(existing)]) == 2
    assert "exists; pass another --out, or add --force" in one_error_line(capsys, "export")
    assert existing.read_text() == "mine\n"
    assert bench(["export", str(run), "--out", str(existing), "--force"]) == 0
    assert existing.read_text().startswith(BOP_HEAD)
    assert bench(["export", str(run), "--out", str(tmp_path / "m_ycbv-test.csv")]) == 2
    line = one_error_line(capsys, "export")
    assert "names dataset 'ycbv', but run" in line and "is of dataset 'toy'; name it m_toy-test.csv" in line
    assert not (tmp_path / "m_ycbv-test.csv").exists()


def test_case_04_templates_into_an_existing_file_needs_force_and_a_templates_file(tmp_path, capsys):
    out = tmp_path / "run.yaml"
    out.write_text("method: {name: icp}\nseed: 0\n")  # another config: its keys are no categories
    args = ["templates", "dataset=synthetic", "--category", "mug", "--k", "2", "--out", str(out)]
    assert bench(args) == 2
    assert "exists; pass another --out, or add --force" in one_error_line(capsys, "templates")
    assert bench([*args, "--force"]) == 2
    assert "'method' is not a category with a list of template ids" in one_error_line(capsys, "templates")
    assert out.read_text() == "method: {name: icp}\nseed: 0\n"


def test_case_05_report_into_its_run_and_score_into_the_gt_run_are_refused(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0, 10.0]), CFG)
    before = snapshot(run)
    assert bench(["report", str(run), "--out", str(run), "--no-pdf"]) == 2
    assert "is the input run itself" in one_error_line(capsys, "report")
    assert bench(["report", str(run), "--out", str(run / "report"), "--no-pdf", "--force"]) == 2
    assert "lies inside the input run" in one_error_line(capsys, "report")
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0, 9.0]))
    assert bench(["score", str(preds), "--gt", str(run), "--method", "m", "--out", str(run / "sub")]) == 2
    assert "lies inside the --gt run" in one_error_line(capsys, "score")
    assert snapshot(run) == before


# ---------------------------------------------------------------------------------------------
# silent wrong results (must refuse or say so)


def test_case_06_one_config_under_two_output_roots_is_two_rows_not_one_pooled(tmp_path, capsys):
    name = "synthetic-gt_model/ours/seed0-default-1a2b3c4d"
    a = write_run(tmp_path / "A" / name, rows([5.0, 40.0, 3.0]), CFG)
    b = write_run(tmp_path / "B" / name, rows([6.0, 41.0, 4.0]), CFG)
    assert bench(["table", str(a), str(b), "--format", "csv", "--metrics", "n,mean"]) == 0
    out = capsys.readouterr().out
    assert "Ours (A)," in out and "Ours (B)," in out
    assert ",6," not in out and ",6.0," not in out  # never 6 rows (n = 2 x 3) from 3 samples each


def _write_bop_with_targets(root: Path) -> Path:
    from test_bad_inputs import write_bop

    write_bop(root)
    targets = [{"scene_id": 1, "im_id": 0, "obj_id": 19, "inst_count": 1}]
    (root / "test_targets_bop19.json").write_text(json.dumps(targets))
    return root


def test_case_07_a_missing_bop_depth_png_is_a_failed_sample_with_its_reason(tmp_path):
    from catpose.datasets.bop import BOP

    root = _write_bop_with_targets(tmp_path / "bop")
    (root / "test/000001/depth/000000.png").unlink()
    ds = BOP(str(root), categories={19: "basket"})
    assert ds.observation_ids() == ["basket/000001/000000/0"]  # the target stays: 1 of 1, not 0
    assert any("1 targets have no depth image" in f and "they fail as samples" in f for f in ds.filters)
    with pytest.raises(DatasetError, match=r"depth image .*000000.png does not exist"):  # what the runner records
        ds.observation("basket/000001/000000/0")
    (root / "test_targets_bop19.json").unlink()  # no target list: frames without depth are left out, and said
    with pytest.raises(DatasetError, match="no depth frames"), pytest.warns(UserWarning, match="no frame shows"):
        BOP(str(root), categories={19: "basket"}).observation_ids()


def test_case_09_bop_ar_without_vsd_is_not_computed_nor_labelled_ar():
    import pandas as pd

    from catpose.bench.scoring.bop_eval import format_scores, score_table

    df = pd.DataFrame(
        {
            "obj_id": [1],
            "category": ["can"],
            "mssd": [1.0],
            "mspd": [1.0],
            "diameter": [100.0],
            "im_width": [640],
            "vsd": [None],
        }  # fmt: skip
    )
    table = score_table(df, ["ar", "ar_mssd", "ar_mspd"], ["category"])
    assert table["ar"].isna().all() and (table["ar_mssd"] == 1.0).all()  # never (MSSD + MSPD) / 2 called ar
    assert "no VSD" in format_scores(table) and "ar not computed" in format_scores(table)


def test_case_11_an_edited_yaw_beside_r00_r22_is_refused_not_ignored(tmp_path):
    from catpose.datasets.alignment import FLIP, read_alignment_table

    head = "category,instance_id,r00,r01,r02,r10,r11,r12,r20,r21,r22,yaw_deg,flip\n"
    t = tmp_path / "t.csv"
    t.write_text(head + "a,a1,1,0,0,0,1,0,0,0,1,90,false\n")  # yaw edited to 90, the matrix left at 0
    with pytest.raises(
        DatasetError, match=r"line 2: yaw_deg = 90 \(flip false\) and r00..r22 \(a yaw of 0 deg\) disagree"
    ):
        read_alignment_table(t)
    t.write_text(head + "a,a1,1,0,0,0,1,0,0,0,1,nan,false\n")
    with pytest.raises(DatasetError, match="line 2: yaw_deg = nan is not a finite number"):
        read_alignment_table(t)
    t.write_text(head + "a,a1,,,,,,,,,,90,true\n")  # the documented fix: yaw_deg (and flip), r00..r22 cleared
    R = read_alignment_table(t)[("a", "a1")]
    assert np.allclose(R, np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]]) @ FLIP)
    t.write_text(head + "a,a1,1,0,0,0,-1,0,0,0,-1,0,true\n")  # both, agreeing (align.py writes both)
    assert np.allclose(read_alignment_table(t)[("a", "a1")], FLIP)


def test_case_12_a_limited_run_is_its_own_folder_never_the_fuller_one(tmp_path, capsys):
    """A subset is another sample set (issue 59): its own run directory and label; the full run's
    folder keeps its 3 samples and its overrides."""
    from test_bad_inputs import toy_cfg

    from catpose.bench.report.labels import _overrides
    from catpose.bench.report.runs import load_run
    from catpose.bench.run.runner import run

    out = run(toy_cfg(tmp_path))  # 3 samples
    cfg = toy_cfg(tmp_path, ["limit=1", "print_summary=true"])
    limited = run(cfg, ["limit=1"])
    printed = capsys.readouterr().out
    assert limited != out and "run directory holds" not in printed
    assert (limited / "summary.md").read_text().strip() in printed  # n = 1
    assert len(load_run(out).samples) == 3 and len(load_run(limited).samples) == 1
    assert (out / "overrides.txt").read_text().strip() == "" and _overrides(load_run(limited)) == ["limit=1"]


def test_case_13_regress_with_a_method_no_suite_has_is_refused(capsys):
    assert bench(["regress", "--suite", "synthetic", "--methods", "nope"]) == 2
    line = one_error_line(capsys, "regress")
    assert "--methods nope: not a method of the suites run (synthetic); choose among" in line and "icp" in line


def test_case_14_inverse_is_applied_to_a_per_sample_csv_and_refused_for_a_bop_csv(tmp_path, capsys):
    gt = write_run(tmp_path / "gt", rows([5.0, 10.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([5.0, 10.0]), inverse=True)  # T_camera_template
    assert (
        bench(["score", str(preds), "--gt", str(gt), "--method", "m", "--out", str(tmp_path / "o"), "--inverse"]) == 0
    )
    assert [round(r["err_deg"], 6) for r in read_rows(tmp_path / "o" / "samples.jsonl")] == [5.0, 10.0]
    bop = tmp_path / "m_toy-test.csv"
    bop.write_text(f"{BOP_HEAD}\n1,0,1,1,{ROT},0 0 0,1\n")
    assert bench(["score", str(bop), "--gt", str(gt), "--out", str(tmp_path / "o2"), "--inverse"]) == 2
    assert "is a BOP results CSV" in one_error_line(capsys, "score") and not (tmp_path / "o2").exists()


def test_case_15_a_killed_run_is_said_to_be_incomplete_by_table_report_and_export(tmp_path, capsys, monkeypatch):
    from test_bad_inputs import toy_cfg

    from catpose.bench.run import runner

    calls = []
    real = runner.run_one

    def killed_on_the_third(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt  # what kill leaves: the samples so far, no end of run
        return real(*args, **kwargs)

    monkeypatch.setattr(runner, "run_one", killed_on_the_third)
    cfg = toy_cfg(tmp_path)
    cfg.dataset.num_views = 4
    with pytest.raises(KeyboardInterrupt):
        runner.run(cfg)
    out = next((tmp_path / "out").rglob("samples.jsonl")).parent
    assert json.loads((out / "run.json").read_text())["state"] == "running"
    capsys.readouterr()
    assert bench(["table", str(out)]) == 0
    o, e = capsys.readouterr()
    assert f"Incomplete: run {out} is incomplete: it holds 2 samples of the 4" in o and "bench table: warning: run" in e
    assert bench(["export", str(out), "--out", str(tmp_path / "m_toy-test.csv")]) == 2  # toy data: no BOP ids
    assert "is incomplete" in capsys.readouterr().err
    assert bench(["report", str(out), "--out", str(tmp_path / "rep"), "--no-pdf"]) == 0
    assert "Incomplete: run" in (tmp_path / "rep" / "index.md").read_text()
    monkeypatch.setattr(runner, "run_one", real)
    runner.run(cfg)  # resumed to the end: finished
    assert json.loads((out / "run.json").read_text())["state"] == "finished"


def test_case_17_data_check_reads_every_depth_png_header_and_model(tmp_path):
    from test_bad_inputs import write_bop

    from catpose.datasets.bop import BOP
    from catpose.datasets.bop_check import check_bop_files
    from catpose.datasets.layout_check import LayoutReport

    root = write_bop(tmp_path / "bop")
    depth = root / "test/000001/depth"
    from PIL import Image

    Image.fromarray(np.full((240, 320), 500, np.uint16)).save(depth / "000000.png")
    Image.fromarray(np.full((240, 320), 500, np.uint16)).save(depth / "000001.png")
    import trimesh

    trimesh.creation.box().export(root / "models" / "obj_000019.ply")
    ds = BOP(str(root), categories={19: "basket"})
    scenes = [root / "test/000001"]
    good = LayoutReport()
    check_bop_files(ds.layout, scenes, {19}, good)
    assert good.problems == []
    data = (depth / "000001.png").read_bytes()
    (depth / "000001.png").write_bytes(data[: len(data) - 20])  # cut off
    Image.fromarray(np.full((120, 160), 500, np.uint16)).save(depth / "000002.png")  # another size
    ply = (root / "models" / "obj_000019.ply").read_bytes()
    (root / "models" / "obj_000019.ply").write_bytes(ply[: len(ply) - 40])  # a truncated model
    bad = LayoutReport()
    check_bop_files(ds.layout, scenes, {19}, bad)
    text = "\n".join(bad.problems)
    assert "000001.png is not a whole PNG" in text and "000002.png is 160x120, not 320x240" in text
    assert "obj_000019.ply cannot be read as a mesh" in text


def test_case_18_templates_tau_of_minus_one_is_refused(tmp_path, capsys):
    args = ["templates", "dataset=synthetic", "--category", "mug", "--k", "2", "--out", str(tmp_path / "t.yaml")]
    assert bench([*args, "--tau", "-1"]) == 2
    assert "--tau -1 must be a distance > 0" in one_error_line(capsys, "templates")
    assert not (tmp_path / "t.yaml").exists()


def test_case_20_empty_sample_ids_are_refused(tmp_path):
    from test_bad_inputs import toy_cfg

    from catpose.bench.run.runner import run

    with pytest.raises(ConfigError, match=r"sample_ids=.* lists no sample"):
        run(toy_cfg(tmp_path, ["sample_ids=[]"]))


def test_case_20_table_categories_no_run_has_are_refused(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    assert bench(["table", str(run), "--categories", "nope"]) == 2
    assert "--categories nope: no run here has that category; they have mug" in one_error_line(capsys, "table")


def test_case_20_a_bop_score_that_is_no_number_is_refused(tmp_path):
    from catpose.bench.interop.prediction_io import read_predictions

    path = tmp_path / "m_toy-test.csv"
    path.write_text(f"{BOP_HEAD}\n1,0,1,abc,{ROT},0 0 0,1\n")
    with pytest.raises(InvalidInputError, match=r"m_toy-test.csv:2: score must be a finite number, got 'abc'"):
        read_predictions(path)


def test_case_20_an_elevation_range_upside_down_is_refused():
    from catpose.datasets.synthetic import SyntheticDataset
    from catpose.datasets.views import ViewOptions

    with pytest.raises(ConfigError, match=r"elevation_min_deg=60.*elevation_max_deg=10.*0 <= elevation_min_deg"):
        SyntheticDataset(view=ViewOptions(elevation_min_deg=60.0, elevation_max_deg=10.0))


def test_case_20_evaluate_of_a_zero_byte_run_json_is_refused(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    (run / "run.json").write_bytes(b"")
    assert bench(["evaluate", str(run)]) == 2
    assert "run.json is unreadable (an empty file)" in one_error_line(capsys, "evaluate")


def test_case_20_export_of_an_estimate_that_is_no_rotation_is_refused(tmp_path, capsys):
    bad = with_bop_ids(rows([5.0]))
    bad[0]["T_est"] = (np.diag([2.0, 2.0, 2.0, 1.0])).ravel().tolist()
    run = write_run(tmp_path / "run", bad, CFG)
    assert bench(["export", str(run), "--out", str(tmp_path / "m_toy-test.csv")]) == 2
    assert "T_est is not a rotation and translation" in one_error_line(capsys, "export")
    assert not (tmp_path / "m_toy-test.csv").exists()


# ---------------------------------------------------------------------------------------------
# tracebacks (must be exit 2 and one line)


def test_case_22_score_out_dot_is_one_line(tmp_path, capsys, monkeypatch):
    gt = write_run(tmp_path / "runs" / "gt", rows([5.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([5.0]))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert bench(["score", str(preds), "--gt", str(gt), "--method", "m", "--out", ".", "--force"]) == 2
    assert "--out . is the current folder or holds it" in one_error_line(capsys, "score")


def test_case_23_report_of_an_empty_run_is_one_line_and_leaves_no_folder(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    (run / "samples.jsonl").write_text("")
    assert bench(["report", str(run), "--out", str(tmp_path / "rep"), "--no-pdf"]) == 2
    assert "has no sample rows (samples.jsonl is empty" in one_error_line(capsys, "report")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_case_24_report_out_a_file_and_table_out_a_folder_are_one_line(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    assert bench(["report", str(run), "--out", str(tmp_path / "afile"), "--force"]) == 2
    assert "is a file; pass a folder" in one_error_line(capsys, "report")
    assert bench(["table", str(run), "--out", str(tmp_path / "adir"), "--force"]) == 2
    assert "is a folder; pass the file to write" in one_error_line(capsys, "table")


def test_case_25_table_and_report_on_a_full_disk_are_one_line_and_leave_nothing(tmp_path, capsys, monkeypatch):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)

    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")

    for move in ("replace", "link", "rename"):  # a new file is linked into place, a folder renamed (issue 60)
        monkeypatch.setattr(atomic.os, move, full)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert bench(["table", str(run), "--out", str(tmp_path / "t.md")]) == 2
    assert "(the disk is full: No space left on device)" in one_error_line(capsys, "table")
    assert bench(["report", str(run), "--out", str(tmp_path / "rep"), "--no-pdf"]) == 2
    assert "cannot write --out" in one_error_line(capsys, "report")
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no file, no half-built folder


def test_case_27_templates_out_an_existing_non_yaml_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "t.yaml"
    bad.write_text("a: [unclosed\n  b: :\n")
    args = ["templates", "dataset=synthetic", "--category", "mug", "--k", "2", "--force"]
    assert bench([*args, "--out", str(bad)]) == 2
    assert "is not valid YAML" in one_error_line(capsys, "templates")
    (tmp_path / "t.csv").write_text("a,b\n")
    assert bench([*args, "--out", str(tmp_path / "t.csv")]) == 2
    assert "end its name in .yaml" in one_error_line(capsys, "templates")


@pytest.mark.parametrize("command", ["table", "evaluate", "export"])
def test_case_28_a_T_est_of_3_numbers_is_one_line_naming_the_line(tmp_path, capsys, command):
    run = write_run(tmp_path / "run", rows([5.0, 6.0]), CFG)
    lines = (run / "samples.jsonl").read_text().splitlines()
    row = json.loads(lines[1])
    row["T_est"] = [1, 2, 3]
    lines[1] = json.dumps(row)
    (run / "samples.jsonl").write_text("\n".join(lines) + "\n")
    args = {
        "table": [str(run)],
        "evaluate": [str(run)],
        "export": [str(run), "--out", str(tmp_path / "m_toy-test.csv")],
    }
    assert bench([command, *args[command]]) == 2
    assert "samples.jsonl:2: T_est is not 16 numbers (3 values)" in one_error_line(capsys, command)


# ---------------------------------------------------------------------------------------------
# unclear messages


def test_case_30_a_bad_row_after_blank_lines_is_named_by_its_own_line(tmp_path):
    from catpose.bench.interop.prediction_io import read_predictions

    path = tmp_path / "p.csv"
    path.write_text(f"sample_id,R,t\n\nmug/i0/v0,{ROT},0 0 0\n\n\nmug/i1/v0,{ROT},0 x 0\n")
    with pytest.raises(InvalidInputError, match=r"p.csv:6 t: expected 3"):
        read_predictions(path)


def test_case_32_a_csv_row_with_extra_fields_says_so(tmp_path):
    from catpose.bench.interop.prediction_io import read_predictions

    path = tmp_path / "p.csv"
    path.write_text(f"sample_id,R,t\nmug/i0/v0,{ROT},0 0 0,extra\n")
    with pytest.raises(InvalidInputError, match=r"p.csv:2: 4 fields, but the header has 3 \(sample_id,R,t\)"):
        read_predictions(path)


def test_case_33_scenes_that_name_no_folder_blame_dataset_scenes(tmp_path):
    from test_bad_inputs import write_bop

    from catpose.datasets.bop import BOP

    root = write_bop(tmp_path / "bop")
    with pytest.raises(DatasetError, match=r"dataset.scenes lists \[99\], which has no folder .*\(its scenes: 1\)"):
        BOP(str(root), scenes=[99]).observation_ids()
