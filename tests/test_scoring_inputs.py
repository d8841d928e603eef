"""No bad prediction is scored as good, and every bad input is one line with exit status 2 (issue 23).

Cases: poses that are not rotations, missing targets (misses, as in bop_toolkit), duplicates
(one documented rule each, with a count), unknown ids (counted and listed), and the inputs that
gave tracebacks: an empty or binary predictions file, empty or non-integer ids, a ground-truth
run without ground truth, an export into a folder or of a run without estimates, a cut-off
regression reference, ``-m`` with ``--cfg``, an alignment table with nan/inf, a duplicate row,
or that misses instances.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from catpose.bench.cli import main as bench
from catpose.bench.interop.prediction_io import read_predictions
from catpose.bench.interop.score import count_text, score_predictions
from catpose.bench.run.rundir import read_rows
from catpose.errors import InvalidInputError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import CFG, one_error_line, rows, write_run  # noqa: E402

ROT = "1 0 0 0 1 0 0 0 1"
BOP_HEAD = "scene_id,im_id,obj_id,score,R,t,time"


@pytest.fixture()
def gt(tmp_path) -> Path:
    return write_run(tmp_path / "gt", rows([5.0, 10.0, 20.0]), CFG)


# ---------------------------------------------------------------------------------------------
# 5. scoring only what is a pose


@pytest.mark.parametrize(
    "R, why",
    [
        ("0 0 0 0 0 0 0 0 0", "det R = 0"),  # all zeros: was scored as the identity
        ("5 0 0 0 5 0 0 0 5", "max |R^T R - I| = 24"),  # 5 R: was scored as perfect
        ("1 0 0 0 1 0 0 0 -1", "det R = -1"),  # a reflection: was scored as a rotation
        ("1 0 0 0 1 0 0 0 1.01", "max |R^T R - I| = 0.0201"),  # 1e-2 off: beyond the 1e-3 tolerance
    ],
)
def test_a_matrix_that_is_not_a_rotation_is_refused_with_its_line(tmp_path, gt, capsys, R, why):
    path = tmp_path / "p.csv"
    path.write_text(f"sample_id,R,t\nmug/i0/v0,{ROT},0 0 0\nmug/i1/v0,{R},0 0 0\n")
    with pytest.raises(InvalidInputError, match=rf"p.csv:3: R is not a rotation \({'.*' if 'I|' in why else ''}"):
        read_predictions(path)
    assert bench(["score", str(path), "--gt", str(gt), "--method", "m", "--out", str(tmp_path / "o")]) == 2
    line = one_error_line(capsys, "score")
    assert "p.csv:3: R is not a rotation" in line and why in line and "det +1 (within 0.001)" in line
    assert not (tmp_path / "o").exists()


def test_rounded_rotations_within_the_tolerance_are_scored(tmp_path, gt):
    c, s = np.cos(0.3), np.sin(0.3)
    R = " ".join(f"{x:.5f}" for x in (c, -s, 0, s, c, 0, 0, 0, 1))  # 5 decimals: about 1e-5 off
    (tmp_path / "p.csv").write_text(f"sample_id,R,t\nmug/i0/v0,{R},0 0 0\n")
    assert len(read_predictions(tmp_path / "p.csv")) == 1


def test_per_sample_duplicates_keep_the_last_row_as_runs_do_and_are_counted(tmp_path, gt):
    from catpose.bench.interop.score import gt_rows_from_run

    def turned(deg: float) -> str:  # R of an estimate turned by deg about z
        return " ".join(map(str, np.reshape(rows([deg])[0]["T_est"], (4, 4))[:3, :3].ravel()))

    (tmp_path / "p.csv").write_text(
        "sample_id,R,t,score\n"
        f"mug/i0/v0,{turned(30.0)},0 0 0,0.1\n"
        f"mug/i0/v0,{turned(3.0)},0 0 0,0.9\n"
        f"mug/i9/v0,{ROT},0 0 0,0.1\n"
        f"nosuch,{ROT},0 0 0,0.1\n"
    )
    stats: dict = {}
    out = score_predictions(read_predictions(tmp_path / "p.csv"), gt_rows_from_run(gt)[0], "m", stats=stats)
    assert out[0]["err_deg"] == pytest.approx(3.0, abs=1e-6)  # the last row of mug/i0/v0
    assert [r["status"] for r in out] == ["ok", "failed", "failed"]  # i1 and i2 have none: misses
    assert stats["duplicates_ignored"] == 1 and stats["missing"] == 2 and stats["scored"] == 1
    assert stats["unknown_ids"] == 2 and stats["unknown_examples"] == ["'mug/i9/v0'", "'nosuch'"]
    text = count_text(stats)
    assert "1 duplicate row(s) ignored (the last row of a sample id counts)" in text
    assert "2 row(s) with 2 id(s) that no sample has, ignored: 'mug/i9/v0', 'nosuch'" in text
    assert "2 without a prediction (counted as misses" in text


def _bop_rows(n: int) -> list[dict]:
    out = rows([5.0 * (k + 1) for k in range(n)])
    for k, r in enumerate(out):
        r["info"] = {"scene_id": 1, "im_id": k, "obj_id": 3, "scale_mm": 100.0}
    return out


def test_bop_duplicates_keep_the_highest_score_and_missing_targets_are_misses(tmp_path):
    from catpose.bench.interop.bop_export import export_bop
    from catpose.bench.interop.score import gt_rows_from_run

    run = write_run(tmp_path / "run", _bop_rows(3), CFG)
    csv = tmp_path / "m_toy-test.csv"
    export_bop(run, csv)
    lines = csv.read_text().splitlines()
    worse = lines[1].split(",")
    worse[3], worse[4] = "0.01", ROT  # a lower-scored second estimate of image 0: ignored, counted
    unknown = lines[1].split(",")
    unknown[2] = "77"  # an object no sample has
    (tmp_path / "x_toy-test.csv").write_text(
        "\n".join([lines[0], lines[1], ",".join(worse), lines[3], ",".join(unknown)]) + "\n"
    )  # image 1 (line 3) missing
    stats: dict = {}
    out = score_predictions(read_predictions(tmp_path / "x_toy-test.csv"), gt_rows_from_run(run)[0], "m", stats=stats)
    assert [r["status"] for r in out] == ["ok", "failed", "ok"] and out[1]["error"] == "no prediction"
    assert out[0]["err_deg"] == pytest.approx(5.0, abs=1e-4) and out[2]["err_deg"] == pytest.approx(15.0, abs=1e-4)
    assert stats["duplicates_ignored"] == 1 and stats["unknown_rows"] == 1
    assert stats["unknown_examples"] == ["scene 1 image 0 object 77"]
    assert "highest-scored" in count_text(stats)


def test_bop_matching_with_missing_targets_gives_misses_not_an_index_error():
    """Finding 2: `_match` returned [] for an (image, object) without estimates: IndexError."""
    from catpose.bench.scoring.bop_eval import _match

    assert _match([], "mssd", 2) == [None, None]
    errors = [[{"mssd": 5.0}, {"mssd": 1.0}]]  # one estimate, two instances: the nearer one matches
    assert _match(errors, "mssd", 2) == [None, 1.0]


# ---------------------------------------------------------------------------------------------
# 7. one line and exit status 2


def _write(path: Path, content: bytes | str) -> Path:
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    return path


@pytest.mark.parametrize(
    "name, content, needle",
    [
        ("m_toy-test.csv", b"", "is empty; write a header"),
        (
            "m_toy-test.csv",
            b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, 'shape': (1, 4, 4), }",
            "is not a text CSV (binary data, e.g. a .npy)",
        ),
        (
            "m_toy-test.npy",
            b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, 'shape': (1, 4, 4), }",
            "m_toy-test.npy is not a text CSV (binary data, e.g. a .npy)",
        ),  # a NumPy file is no prediction file
        (
            "m_toy-test.csv",
            f"{BOP_HEAD}\n,0,3,1,{ROT},0 0 0,1\n",
            "m_toy-test.csv:2: scene_id must be an integer, got ''",
        ),
        (
            "m_toy-test.csv",
            f"{BOP_HEAD}\n1,0.5,3,1,{ROT},0 0 0,1\n",
            "m_toy-test.csv:2: im_id must be an integer, got '0.5'",
        ),
        (
            "m_toy-test.csv",
            f"{BOP_HEAD}\n1,0,x,1,{ROT},0 0 0,1\n",
            "m_toy-test.csv:2: obj_id must be an integer, got 'x'",
        ),
        ("m_toy-test.csv", f"sample_id,R,t\n ,{ROT},0 0 0\n", "m_toy-test.csv:2: sample_id is empty"),
        (
            "m_toy-test.csv",
            f"sample_id,R,t\nmug/i0/v0,{ROT},0 nan 0\n",
            "m_toy-test.csv:2 t: has a NaN or infinite value",
        ),
    ],
)
def test_bad_prediction_files_are_one_line(tmp_path, gt, capsys, name, content, needle):
    path = _write(tmp_path / name, content)
    rc = bench(["score", str(path), "--gt", str(gt), "--method", "m", "--out", str(tmp_path / "o")])
    line = one_error_line(capsys, "score")
    assert rc == 2 and needle in line, line
    assert not (tmp_path / "o").exists()


def test_a_header_only_bop_file_scores_every_target_as_a_miss(tmp_path, capsys):
    run = write_run(tmp_path / "run", _bop_rows(2), CFG)
    path = _write(tmp_path / "m_toy-test.csv", BOP_HEAD + "\n")
    assert bench(["score", str(path), "--gt", str(run), "--out", str(tmp_path / "o")]) == 0
    assert "0 of 2 samples scored, 2 without a prediction (counted as misses" in capsys.readouterr().out
    assert [r["error"] for r in read_rows(tmp_path / "o" / "samples.jsonl")] == ["no prediction"] * 2


def test_a_gt_run_without_ground_truth_is_one_line(tmp_path, capsys):
    failed = [dict(r, status="failed", T_est=None, T_gt=None, error="load failed") for r in rows([1.0, 2.0])]
    run = write_run(tmp_path / "run", failed, CFG)
    path = _write(tmp_path / "p.csv", f"sample_id,R,t\nmug/i0/v0,{ROT},0 0 0\n")
    assert bench(["score", str(path), "--gt", str(run), "--method", "m", "--out", str(tmp_path / "o")]) == 2
    assert "has no sample with ground truth (2 rows, all failed before their data loaded)" in one_error_line(
        capsys, "score"
    )


def test_export_into_a_folder_or_of_a_run_without_estimates_is_one_line(tmp_path, gt, capsys):
    (tmp_path / "m_toy-test.csv").mkdir()
    assert bench(["export", str(gt), "--out", str(tmp_path / "m_toy-test.csv")]) == 2
    assert "is a folder; pass the file to write, e.g. " in one_error_line(capsys, "export")
    failed = [dict(r, status="failed", T_est=None, error="no convergence") for r in rows([1.0, 2.0])]
    run = write_run(tmp_path / "failed", failed, CFG)
    out = tmp_path / "f_toy-test.csv"
    assert bench(["export", str(run), "--out", str(out)]) == 2
    assert "has no sample with an estimate (2 samples, all failed); nothing to export" in one_error_line(
        capsys, "export"
    )
    assert not out.exists()


def test_export_says_what_it_skipped(tmp_path, capsys):
    some = _bop_rows(3)
    some[1] = dict(some[1], status="failed", T_est=None, error="no convergence")
    run = write_run(tmp_path / "run", some, CFG)
    assert bench(["export", str(run), "--out", str(tmp_path / "m_toy-test.csv")]) == 0
    out, err = capsys.readouterr()
    assert "wrote 2 estimates" in out
    assert (
        "bench export: warning: skipped: 1 of 3 samples have no estimate (failed) and are not in the file, e.g. mug/i1/v0: "
        "no convergence" in err
    )


def _regress_config(tmp_path: Path, reference: Path, inputs: Path | None = None) -> Path:
    cfg = {
        "gate": {},
        "suites": {
            "s": {
                "dataset": "synthetic",
                "protocol": "gt_model",
                "methods": ["icp"],
                "reference": str(reference),
                **({"inputs": str(inputs)} if inputs else {}),
            }
        },
    }
    path = tmp_path / "regress.yaml"
    path.write_text(json.dumps(cfg))  # JSON is YAML
    return path


def test_regress_on_a_cut_off_reference_is_exit_2_not_1(tmp_path, capsys):
    ref = _write(tmp_path / "ref.json", '{"format": 2, "methods": {"icp": {"samp')
    rc = bench(["regress", "--config", str(_regress_config(tmp_path, ref)), "--jobs", "1"])
    line = one_error_line(capsys, "regress")
    assert rc == 2 and "reference" in line and "cannot be read (JSONDecodeError" in line and "--update" in line


def test_regress_on_a_cut_off_golden_npz_is_exit_2_not_1(tmp_path, capsys):
    from catpose.bench.protocols.absolute import GtModel
    from catpose.bench.regress.golden import write_golden
    from catpose.datasets.synthetic import SyntheticDataset

    ds = SyntheticDataset(categories=["mug"], instances_per_category=1, views_per_instance=1)
    npz = tmp_path / "inputs.npz"
    write_golden(npz, "s", [], [GtModel().load(ds, ds.observation_ids()[0])])
    data = npz.read_bytes()
    npz.write_bytes(data[: len(data) // 2])
    ref = _write(tmp_path / "ref.json", json.dumps({"format": 2, "methods": {"icp": {"samples": {}}}}))
    rc = bench(["regress", "--config", str(_regress_config(tmp_path, ref, npz)), "--jobs", "1"])
    line = one_error_line(capsys, "regress")
    assert rc == 2 and f"golden inputs {npz} cannot be read" in line


def test_multirun_with_cfg_is_one_line(capsys):
    assert bench(["run", "-m", "method=icp,ours", "dataset=synthetic", "--cfg", "job"]) == 2
    line = one_error_line(capsys, "run")
    assert "-m and --cfg cannot be combined" in line and "bench run method=icp --cfg job" in line


# ---------------------------------------------------------------------------------------------
# 6. alignment tables that check


def _box_dataset(root: Path, table: Path, categories=("box",)):
    from test_protocol_refusal import _box_off

    from catpose.datasets.modelnet40 import ModelNet40, ShapeFrame
    from catpose.datasets.templates import TemplateOptions

    for name in ("box_0001", "box_0002"):
        if not (root / f"box/train/{name}.off").exists():
            _box_off(root / f"box/train/{name}.off", (2.0, 1.0, 0.5))
    return ModelNet40(
        str(root),
        categories=list(categories),
        split="train",
        views_per_instance=1,
        template=TemplateOptions(templates={"box": ["box_0001"]}, template_points=200),
        frame=ShapeFrame(alignment_table=str(table)),
    )


@pytest.mark.parametrize(
    "body, needle",
    [
        ("box,box_0001,0\nbox,box_0002,nan\n", "line 3: yaw_deg = nan is not a finite number"),
        ("box,box_0001,inf\nbox,box_0002,0\n", "line 2: yaw_deg = inf is not a finite number"),
        ("box,box_0001,0\nbox,box_0002,90\nbox,box_0001,180\n", "lines 2 and 4: two rows for box/box_0001"),
        ("box,box_0001,0\n", "has no row for 1 of the 2 box instances used (e.g. box_0002; the table covers box)"),
        (
            "chair,chair_0001,0\nchair,chair_0002,90\n",
            "has no row for 2 of the 2 box instances used (e.g. box_0001; the table covers chair)",
        ),
        ("box,nosuch_1,0\nbox,nosuch_2,90\n", "has no row for 2 of the 2 box instances used"),
    ],
)
def test_an_alignment_table_that_does_not_check_is_refused_in_one_line(tmp_path, body, needle):
    """Finding 4 and 12: any table unlocked protocol=templates; a nan yaw was blamed on the mesh."""
    from catpose.errors import DatasetError

    table = _write(tmp_path / "t.csv", "category,instance_id,yaw_deg\n" + body)
    with pytest.raises(DatasetError) as e:
        _box_dataset(tmp_path / "mn", table)
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_bench_run_with_another_categorys_table_is_one_line(tmp_path):
    _box_dataset(
        tmp_path / "mn", _write(tmp_path / "ok.csv", "category,instance_id,yaw_deg\nbox,box_0001,0\nbox,box_0002,0\n")
    )  # writes the OFF files
    table = _write(tmp_path / "chair.csv", "category,instance_id,yaw_deg\nchair,chair_0001,0\n")
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "catpose.bench.cli",
            "run",
            "method=icp",
            "dataset=modelnet40",
            f"dataset.root={tmp_path / 'mn'}",
            "dataset.categories=[box]",
            f"dataset.alignment_table={table}",
            "protocol=templates",
            "+dataset.templates.box=[box_0001]",
            f"output_root={tmp_path / 'out'}",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    err = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2 and len(err) == 1, r.stderr[-2000:]
    assert err[0].startswith("bench run: error: ") and "has no row for 2 of the 2 box instances used" in err[0]
    assert not (tmp_path / "out").exists()
