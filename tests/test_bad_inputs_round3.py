"""Issue 60, "files and numbers you can trust, round 3": one test per numbered case, named after it.

Each case runs on toy runs and files made here (no shared data), in-process, in about a second.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from catpose.bench.cli import main as bench
from catpose.bench.run.rundir import read_rows

TESTS = Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))

from _trust import CFG, one_error_line, rows, write_run  # noqa: E402
from test_bad_inputs_round2 import per_sample_csv, snapshot  # noqa: E402


def _score(preds: Path, gt: Path, out: Path, *extra: str) -> int:
    return bench(["score", str(preds), "--gt", str(gt), "--method", "ext", "--out", str(out), *extra])


# ---------------------------------------------------------------------------------------------
# data loss


def test_case_01_perf_out_follows_the_output_rule(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    before = snapshot(run)
    base = ["perf", "--n", "1", "--repeat", "1", "--methods", "icp", "--out"]
    assert bench([*base, str(run / "samples.jsonl"), "--force"]) == 2
    assert "lies inside the run directory" in one_error_line(capsys, "perf")
    other = tmp_path / "mine.csv"
    other.write_text("mine\n")
    assert bench([*base, str(other)]) == 2
    assert "exists; pass another --out, or add --force" in one_error_line(capsys, "perf")
    assert snapshot(run) == before and other.read_text() == "mine\n"


def test_case_02_score_force_never_replaces_a_run_being_written(tmp_path, capsys):
    from catpose.bench.run.rundir import RunLock

    gt = write_run(tmp_path / "gt", rows([5.0, 10.0]), CFG)
    busy = write_run(tmp_path / "busy", rows([1.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0, 9.0]))
    lock = RunLock(busy)
    lock.acquire()
    try:
        before = snapshot(busy)
        assert _score(preds, gt, busy, "--force") == 2
        assert "is a run that pid" in one_error_line(capsys, "score")
        assert snapshot(busy) == before
    finally:
        lock.release()
    assert _score(preds, gt, busy, "--force") == 0  # finished: --force replaces it


def test_case_03_a_new_out_is_claimed_at_the_final_move(tmp_path, capsys, monkeypatch):
    """Two commands writing one new --out: the second fails in one line, the first's output is kept."""
    from catpose.bench.interop import score

    gt = write_run(tmp_path / "gt", rows([5.0, 10.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0, 9.0]))
    race = tmp_path / "race"
    scored = score.score_predictions

    def first_finishes_meanwhile(*args, **kwargs):
        write_run(race, rows([1.0]), CFG)  # the other command's result
        return scored(*args, **kwargs)

    monkeypatch.setattr(score, "score_predictions", first_finishes_meanwhile)
    assert _score(preds, gt, race) == 2
    assert "was written by another command while this one ran; it is kept" in one_error_line(capsys, "score")
    assert [r["method"] for r in read_rows(race / "samples.jsonl")] == ["ours"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_case_03_a_new_file_is_claimed_at_the_final_move(tmp_path):
    from catpose import atomic
    from catpose.bench.run.overwrite import Output
    from catpose.errors import InvalidInputError

    out = Output(tmp_path / "t.md", "file")
    (tmp_path / "t.md").write_text("first\n")
    with pytest.raises(InvalidInputError, match="written by another command while this one ran"):
        with out.writing() as path:
            atomic.write_text(path, "second\n")
    assert (tmp_path / "t.md").read_text() == "first\n"
    assert [p.name for p in tmp_path.iterdir()] == ["t.md"]
    table, side = Output(tmp_path / "u.csv", "file"), Output(tmp_path / "u.csv.map.csv", "file")  # as bench export
    (tmp_path / "u.csv").write_text("first\n")
    with pytest.raises(InvalidInputError, match=r"--out \S*u.csv was written by another command"):
        with table.writing(), side.writing():
            atomic.write_text(table.path, "second\n")


def test_case_04_no_force_over_runs_below(tmp_path, capsys):
    outer = write_run(tmp_path / "outer", rows([5.0]), CFG)
    (outer / "inner").mkdir()  # made by hand (no command makes it)
    (outer / "inner/samples.jsonl").write_bytes((outer / "samples.jsonl").read_bytes())
    gt = write_run(tmp_path / "gt", rows([5.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0]))
    before = snapshot(outer)
    assert _score(preds, gt, outer, "--force") == 2
    assert "holds run directories below it" in one_error_line(capsys, "score")
    assert snapshot(outer) == before


# ---------------------------------------------------------------------------------------------
# silent wrong


def test_case_09_score_with_no_matching_sample_is_refused(tmp_path, capsys):
    gt = write_run(tmp_path / "gt", rows([5.0, 10.0]), CFG)
    other = [dict(r, sample_id=f"airplane/{r['sample_id']}") for r in rows([7.0, 9.0])]
    assert _score(per_sample_csv(tmp_path / "p.csv", other), gt, tmp_path / "o") == 2
    line = one_error_line(capsys, "score")
    assert "no prediction row of" in line and "airplane/mug/i0/v0" in line and "mug/i0/v0" in line
    assert not (tmp_path / "o").exists()


def test_case_11_by_is_checked(tmp_path, capsys):
    gt = write_run(tmp_path / "gt", rows([5.0]), CFG)
    assert bench(["table", str(gt), "--by", "object"]) == 2
    assert "--by 'object' goes with --bop-metrics" in one_error_line(capsys, "table")


def test_case_12_suite_table_only_without_runs_is_refused(tmp_path, monkeypatch, capsys):
    from catpose.bench.real import suite

    monkeypatch.setattr(suite, "run_suite", lambda *a, **k: ({}, {}))
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(tmp_path))
    assert bench(["suite", "real", "--table-only", "--output-root", str(tmp_path / "nonexistent")]) == 2
    assert "--table-only: no run of these sets and methods under" in one_error_line(capsys, "suite")


def test_case_13_30_templates_points_category_and_instances_are_checked(tmp_path, capsys):
    base = ["templates", "dataset=synthetic", "--k", "2", "--out", str(tmp_path / "t.yaml")]
    for extra, said in (
        (["--category", "mug", "--points", "0"], "--points 0: pass at least 64 points"),
        (["--category", "mug", "--points", "3"], "--points 3: pass at least 64 points"),
        (["--category", "nope"], "--category 'nope' has no train instances in dataset synthetic"),
        (["--category", "mug", "--instances", "nope"], "has no train instance nope in dataset synthetic"),
    ):
        assert bench([*base, *extra]) == 2
        assert said in one_error_line(capsys, "templates")
    assert not (tmp_path / "t.yaml").exists()


@pytest.mark.parametrize(
    "override, said",
    [
        ("dataset.fx=nan", "dataset.fx=nan must be a positive number of pixels"),
        ("dataset.roll_max_deg=1000", "dataset.roll_max_deg=1000: pass a roll in [0, 180] degrees"),
        ("dataset.depth_noise_std=-1", "depth_noise_std=-1 must be >= 0"),
        ("dataset.min_points=100000", "min_points=100000 must be in 1..76800"),
        ("retry_failed=maybe", "retry_failed='maybe': pass true or false"),
        ("output_root=/tmp/\u00fc\u00f1\u00ef", "quote a value with spaces or non-ASCII letters"),
        ("--help-me", "unknown option --help-me"),
    ],
)
def test_case_14_26_invalid_settings_are_one_line(tmp_path, capsys, override, said):
    args = ["run", "method=icp", "dataset=synthetic", "limit=1", f"output_root={tmp_path}", override]
    try:
        code = bench(args)
    except SystemExit as e:  # a dataset's options are checked where Hydra's job builds it
        code = e.code
    assert code == 2
    assert said in one_error_line(capsys, "run")
    assert not list(tmp_path.rglob("samples.jsonl"))


def test_a_mapping_given_to_a_group_of_keys_is_one_line(tmp_path, capsys):
    from catpose.bench.run.config import compose

    args = ["run", "method=icp", "dataset=modelnet40", f"output_root={tmp_path}", "dataset.symmetric={can:[0,0,1]}"]
    assert bench(args) == 2
    assert "dataset.symmetric has no keys; a new key in it needs ++" in one_error_line(capsys, "run")
    cfg = compose(["dataset=modelnet40", "++dataset.symmetric={can:[0,0,1]}"])  # as the line says
    assert list(cfg.dataset.symmetric.can) == [0, 0, 1]


def test_case_15_hand_edited_runs_are_named(tmp_path, capsys):
    import json

    for field, value, said in (
        ("status", "banana", "status 'banana' is neither 'ok' nor 'failed'"),
        ("sample_id", " ", "its sample_id is empty"),
        ("T_gt", None, "status 'ok' but T_gt null"),
    ):
        run = write_run(tmp_path / field, rows([5.0, 10.0]), CFG)
        lines = (run / "samples.jsonl").read_text().splitlines()
        lines[1] = json.dumps(dict(json.loads(lines[1]), **{field: value}))
        (run / "samples.jsonl").write_text("\n".join(lines) + "\n")
        assert bench(["export", str(run), "--out", str(tmp_path / f"m_toy-{field.replace('_', '')}.csv")]) == 2
        assert f"samples.jsonl:2: {said}" in one_error_line(capsys, "export")
    for state, n, said in (
        ("exploded", 2, "run.json has state 'exploded'"),
        ("finished", 5, "holds 2 samples of the 5"),
    ):
        run = write_run(tmp_path / state, rows([5.0, 10.0]), CFG)
        info = json.loads((run / "run.json").read_text())
        (run / "run.json").write_text(json.dumps(dict(info, state=state, n_samples=n)))
        assert bench(["table", str(run)]) == 0
        assert said in capsys.readouterr().err


BOP_HEAD = "scene_id,im_id,obj_id,score,R,t,time"
ROT = "1 0 0 0 1 0 0 0 1"


@pytest.mark.parametrize(
    "body, said",
    [
        (f"1,1,1,nan,{ROT},0 0 500,0.1", "p.csv:2: score must be a finite number, got 'nan'"),
        (f"1,1,1,inf,{ROT},0 0 500,0.1", "p.csv:2: score must be a finite number, got 'inf'"),
        (f"1,1,1,0.5,{ROT},0 0 500,nan", "p.csv:2: time must be a finite number (seconds, or -1: not measured)"),
        (f"1,1,1,0.5,{ROT},0 0 500,-5", "p.csv:2: time must be a finite number (seconds, or -1: not measured)"),
        (f"1,1,1,0.5,{ROT},0 0 500,0.1\n1,1,2,0.5,{ROT},0 0 500,0.2", "scene 1 image 1 has different times"),
        ("1,1,1,0.5,1 0 0 0 nan 0 0 0 1,0 0 500,0.1", "p.csv:2 R: has a NaN or infinite value"),
        (f"1,1,1,0.5,{ROT},0 inf 500,0.1", "p.csv:2 t: has a NaN or infinite value"),
        ("1,1,1,0.5,1.0005 0 0 0 1 0 0 0 1,0 0 500,0.1", "max |R^T R - I| = 0.00100025"),
    ],
)
def test_case_16_31_32_bop_csv_numbers_are_checked(tmp_path, capsys, body, said):
    """Cases 16 (NaN/inf score and time, time -5, times differing in one image), 31 (NaN in R or t
    said to be a count), 32 (an R just outside the tolerance shown rounded onto it)."""
    from catpose.bench.interop.prediction_io import read_predictions
    from catpose.errors import InvalidInputError

    path = tmp_path / "p.csv"
    path.write_text(f"{BOP_HEAD}\n{body}\n")
    with pytest.raises(InvalidInputError) as info:
        read_predictions(path)
    assert said in str(info.value)
    path.write_text(f"{BOP_HEAD}\n1,1,1,0.5,{ROT},0 0 500,-1\n")  # -1: BOP's "not measured"
    assert read_predictions(path)["time"].tolist() == [-1.0]


def test_case_34_a_latin1_byte_is_named(tmp_path, capsys):
    gt = write_run(tmp_path / "gt", rows([5.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0]))
    preds.write_bytes(preds.read_bytes() + b"caf\xe9,1,2\n")
    assert _score(preds, gt, tmp_path / "o") == 2
    assert "p.csv:3: byte 0xe9 is not UTF-8 (a file saved as Latin-1?)" in one_error_line(capsys, "score")


# ---------------------------------------------------------------------------------------------
# tracebacks and unclear messages


@pytest.mark.parametrize(
    "args, said",
    [
        (["clutter", "--part", "nope"], "--part 'nope' is not a part of configs/split/clutter.yaml"),
    ],
)
def test_case_19_20_29_options_are_one_line(tmp_path, capsys, args, said):
    command = args[0]
    assert bench(args) == 2
    assert said in one_error_line(capsys, command)
    assert not list(tmp_path.iterdir())


def test_case_21_regress_config_that_is_no_yaml_mapping(tmp_path, capsys):
    csv = tmp_path / "x.csv"
    csv.write_text("a,b\n1,2\n")
    assert bench(["regress", "--config", str(csv)]) == 2
    assert "x.csv has no 'suites' mapping" in one_error_line(capsys, "regress")


def test_case_22_28_symlink_loops_and_files_given_as_runs(tmp_path, capsys):
    gt = write_run(tmp_path / "gt", rows([5.0]), CFG)
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    assert _score(tmp_path / "a", gt, tmp_path / "o") == 2
    assert "is a loop of symbolic links" in one_error_line(capsys, "score")
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0]))
    assert bench(["report", str(preds), "--out", str(tmp_path / "r")]) == 2
    assert f"{preds} is a file; pass run directories" in one_error_line(capsys, "report")


def test_case_22_28_loops_and_folder_samples_given_to_report_table_evaluate(tmp_path, capsys):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    for args in (["report", "--out", str(tmp_path / "r")], ["table"], ["evaluate"]):
        assert bench([args[0], str(tmp_path / "a"), *args[1:]]) == 2
        assert f"{tmp_path / 'a'} is a loop of symbolic links" in one_error_line(capsys, args[0])
    (tmp_path / "run" / "samples.jsonl").mkdir(parents=True)
    for args in (["report", "--out", str(tmp_path / "r")], ["table"], ["evaluate"]):
        assert bench([args[0], str(tmp_path / "run"), *args[1:]]) == 2
        assert "samples.jsonl is a folder, not a file" in one_error_line(capsys, args[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b", "run"]


def test_case_28_37_mesh_paths_and_nan_vertices(tmp_path):
    from catpose.datasets.meshio import read_mesh
    from catpose.errors import DatasetError

    with pytest.raises(DatasetError, match="is a folder, not a file"):
        read_mesh(tmp_path)
    ply = tmp_path / "m.ply"
    ply.write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\nnan nan nan\n0 1 0\n3 0 1 2\n"
    )
    with pytest.raises(DatasetError, match="non-finite vertex coordinates"):
        read_mesh(ply)


@pytest.mark.parametrize(
    "depth_value, K, said",
    [
        (np.inf, np.diag([300.0, 300.0, 1.0]), "none has a depth measurement (4 NaN or inf)"),
        (1.0, np.zeros((3, 3)), "K is all zeros"),
        (1.0, np.array([[300, 0, 2], [0, 300, 2], [0, 0, np.nan]]), "K has a NaN or inf"),
    ],
)
def test_case_33_depth_frame_messages(depth_value, K, said):
    from catpose.depth_frame import DepthFrame
    from catpose.errors import InvalidInputError

    depth = np.ones((4, 4))
    mask = np.zeros((4, 4), bool)
    mask[1:3, 1:3] = True
    depth[mask] = depth_value
    with pytest.raises(InvalidInputError, match=re.escape(said)):
        DepthFrame(depth, K, mask)


def test_case_36_export_name_hint_names_the_runs_dataset(tmp_path, capsys):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    assert bench(["export", str(run), "--out", str(tmp_path / "my results.csv")]) == 2
    line = one_error_line(capsys, "export")
    assert "e.g. my-results_toy-test.csv" in line and "ycbv" not in line


def test_case_15_a_config_naming_another_method_is_named(tmp_path, capsys):
    run = write_run(tmp_path / "run", [dict(r, method="icp") for r in rows([5.0])], dict(CFG, method={"name": "icp"}))
    (run / "config.yaml").write_text((run / "config.yaml").read_text().replace("name: icp", "name: ours", 1))
    assert bench(["table", str(run)]) == 2
    assert "config.yaml names method 'ours' but its rows are of 'icp'" in one_error_line(capsys, "table")


def test_also_a_killed_commands_hidden_folder_is_cleared_by_the_next(tmp_path):
    import subprocess

    from catpose import atomic

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f".r.{int(dead.stdout)}-0123abcd.tmp"
    stale.mkdir()
    (stale / "index.md").write_text("half")
    with atomic.building_dir(tmp_path / "r") as tmp:
        (tmp / "index.md").write_text("whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]


@pytest.mark.slow  # a bench run in a subprocess: about 10 s
def test_also_sigterm_ends_a_run_with_a_line(tmp_path):
    import signal
    import subprocess
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "catpose.bench.cli", "run", "method=icp", "dataset=synthetic", "limit=500",
         f"output_root={tmp_path}", "progress=false"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while not list(tmp_path.rglob("samples.jsonl")) or not next(tmp_path.rglob("samples.jsonl")).stat().st_size:
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "bench run: interrupted; finished samples are saved" in err


def test_case_23_a_flat_template_through_the_api_is_one_line():
    """A flat (zero-volume) template given to catpose.register stops in one line, not in Qhull's
    many-line precision error from the dictionary's hidden-point removal."""
    import numpy as np
    import trimesh

    import catpose
    from catpose.errors import RegistrationFailed

    square = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], faces=[[0, 1, 2], [0, 2, 3]])
    points = np.random.default_rng(0).uniform(0, 1, (300, 3))
    points[:, 2] = 0
    with pytest.raises(RegistrationFailed) as info:
        catpose.register(points, square, method="ours")
    assert "flat or degenerate" in str(info.value) and "\n" not in str(info.value)
