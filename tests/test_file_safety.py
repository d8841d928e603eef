"""Files you can trust (issue 23): atomic writes, readers that never skip in silence, no command
writing into a run it did not create.

docs/file-safety.md states the rules these tests check.
"""

from __future__ import annotations

import errno
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from catpose import atomic
from catpose.bench.cli import main as bench
from catpose.bench.run.rows_file import CutOffLineWarning
from catpose.bench.run.rundir import SampleWriter, read_rows
from catpose.errors import DatasetError, InvalidInputError, RunAborted

TESTS = Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))

from _trust import CFG, one_error_line, rows, with_bop_ids, write_run  # noqa: E402

# ---------------------------------------------------------------------------------------------
# 2. atomic writes


def test_atomic_write_replaces_whole_or_not_at_all(tmp_path):
    path = tmp_path / "run.json"
    atomic.write_text(path, "old\n")
    with pytest.raises(OSError):
        with atomic.atomic_write(path) as f:
            f.write("half of the new")
            raise OSError(errno.ENOSPC, "No space left on device")
    assert path.read_text() == "old\n"  # the old file, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]  # no temporary file left
    atomic.write_text(path, "new\n")
    assert path.read_text() == "new\n" and sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]
    with atomic.atomic_path(tmp_path / "fig.png") as tmp:  # libraries that pick a format from the suffix
        assert tmp.suffix == ".png" and tmp.parent == tmp_path
        tmp.write_bytes(b"png")
    assert (tmp_path / "fig.png").read_bytes() == b"png"


def test_a_full_disk_while_writing_run_json_keeps_the_old_one(tmp_path, monkeypatch):
    """Finding 9: a full disk left a 0-byte run.json and every table failed with a traceback."""
    from catpose.bench.run import rundir

    rundir.write_run_json(tmp_path, {"n_samples": 3})
    before = (tmp_path / "run.json").read_text()

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic.os, "fsync", full)
    with pytest.raises(RunAborted, match="the disk is full"):
        rundir.write_run_json(tmp_path, {"n_samples": 4})
    assert (tmp_path / "run.json").read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]


def test_building_dir_moves_a_complete_folder_or_nothing(tmp_path):
    final = tmp_path / "run"
    with pytest.raises(RuntimeError):
        with atomic.building_dir(final) as tmp:
            (tmp / "samples.jsonl").write_text("{}\n")
            raise RuntimeError("scoring failed half-way")
    assert list(tmp_path.iterdir()) == []  # no half-written output folder (finding 2)
    with atomic.building_dir(final) as tmp:
        (tmp / "a").write_text("1")
    with atomic.building_dir(final) as tmp:  # the caller allowed replacing it (--force)
        (tmp / "b").write_text("2")
    assert [p.name for p in final.iterdir()] == ["b"] and [p.name for p in tmp_path.iterdir()] == ["run"]


# ---------------------------------------------------------------------------------------------
# 3. readers never skip in silence


def test_a_damaged_line_is_an_error_naming_file_and_line(tmp_path):
    path = tmp_path / "samples.jsonl"
    path.write_text('{"sample_id": "a"}\n{"sample_id": "b", oops}\n{"sample_id": "c"}\n')
    with pytest.raises(DatasetError, match=r"samples.jsonl:2: not a JSON row") as e:
        read_rows(path)
    assert "\n" not in str(e.value)
    path.write_text('{"sample_id": "a"}\n[1, 2]\n{"sample_id": "c"}\n')
    with pytest.raises(DatasetError, match=r"samples.jsonl:2: not a sample row"):
        read_rows(path)


def test_a_cut_off_last_line_warns_with_its_count_and_is_redone_on_resume(tmp_path):
    path = tmp_path / "samples.jsonl"
    path.write_text('{"sample_id": "a"}\n{"sample_id": "b"}\n{"sample_id": "c", "sta')
    with pytest.warns(CutOffLineWarning, match=r"last line \(3\) is cut off.*skipped 1 sample row"):
        assert [r["sample_id"] for r in read_rows(path)] == ["a", "b"]
    w = SampleWriter(path)  # what the runner does on resume: the cut-off row goes, "c" is run again
    w.write({"sample_id": "c", "status": "ok"})
    w.close()
    assert [r["sample_id"] for r in read_rows(path)] == ["a", "b", "c"]
    # a whole last row without its newline is kept, and the next row starts on its own line
    path.write_text('{"sample_id": "a"}')
    w = SampleWriter(path)
    w.write({"sample_id": "b"})
    w.close()
    assert [r["sample_id"] for r in read_rows(path)] == ["a", "b"]


def test_runner_resume_reruns_the_cut_off_sample(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    from test_bad_inputs import toy_cfg

    from catpose.bench.run.runner import run

    out = run(toy_cfg(tmp_path))
    path = out / "samples.jsonl"
    whole = read_rows(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 40])  # a kill in the middle of writing the last row
    with pytest.warns(CutOffLineWarning):
        run(toy_cfg(tmp_path))
    again = read_rows(path)
    assert [r["sample_id"] for r in again] == [r["sample_id"] for r in whole]
    assert again[-1]["T_est"] == whole[-1]["T_est"]


def _copy_run(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


@pytest.fixture()
def two_runs(tmp_path) -> tuple[Path, Path]:
    a = write_run(tmp_path / "runs" / "a", rows([5.0, 40.0, 3.0]), CFG)
    icp_rows = [dict(r, method="icp") for r in rows([6.0, 41.0, 4.0])]  # rows and config.yaml agree (issue 60)
    b = write_run(tmp_path / "runs" / "b", icp_rows, dict(CFG, method={"name": "icp", "_target_": "x.Z"}))
    return a, b


def test_table_leaves_out_a_damaged_run_names_it_and_exits_2(two_runs, capsys, tmp_path):
    """Finding 3: a damaged copy of a run was shown in bold as the best, its bad line skipped."""
    a, b = two_runs
    lines = (a / "samples.jsonl").read_text().splitlines()
    lines[1] = lines[1][:-5] + "#####"  # line 2 damaged (not the last line: no kill does that)
    (a / "samples.jsonl").write_text("\n".join(lines) + "\n")
    rc = bench(["table", str(tmp_path / "runs"), "--format", "csv"])
    out, err = capsys.readouterr()
    assert rc == 2
    assert err.strip().splitlines() == [err.strip()]  # one line
    assert err.startswith("bench table: error: left out: ") and f"{a / 'samples.jsonl'}:2: not a JSON row" in err
    assert "ICP," in out and "Ours," not in out  # the table of the other run is still made


@pytest.mark.parametrize(
    "damage, needle",
    [
        (("run.json", b""), "run.json is unreadable (an empty file)"),
        (("run.json", b'{"method": "ours", "n_sa'), "run.json is unreadable (JSONDecodeError"),
        (("config.yaml", b"method: {name: [unclosed\n"), "config.yaml is unreadable"),
        (("config.yaml", b""), "config.yaml is empty or not a mapping"),
    ],
)
@pytest.mark.parametrize("command", ["table", "report", "export"])
def test_unreadable_metadata_fails_that_run_in_one_line_not_the_others(
    two_runs, tmp_path, capsys, damage, needle, command
):
    a, b = two_runs
    (a / damage[0]).write_bytes(damage[1])
    args = {
        "table": ["table", str(tmp_path / "runs")],
        "report": ["report", str(tmp_path / "runs"), "--out", str(tmp_path / "rep"), "--no-pdf"],
        "export": ["export", str(a), "--out", str(tmp_path / "m_toy-test.csv")],
    }[command]
    rc = bench(args)
    line = one_error_line(capsys, command)
    assert rc == 2 and f"run {a}: {needle}" in line, line
    if command == "report":  # the other run is still reported, and the index says what was left out
        index = (tmp_path / "rep" / "index.md").read_text()
        assert "Left out (unreadable):" in index
        assert "| ICP |" in index and "| Ours |" not in index
    if command == "export":
        assert not (tmp_path / "m_toy-test.csv").exists()


def test_a_table_of_only_unreadable_runs_is_one_line(two_runs, capsys):
    a, _ = two_runs
    (a / "run.json").write_bytes(b"")
    assert bench(["table", str(a)]) == 2
    assert (
        one_error_line(capsys, "table") == f"bench table: error: run {a}: run.json is unreadable (an empty file); "
        "re-run the same `bench run` command to rewrite it (finished samples are skipped), or restore it from a copy"
    )


# ---------------------------------------------------------------------------------------------
# 1. no command writes into a run it did not create


def test_write_run_refuses_an_existing_run_unless_forced(tmp_path):
    run = write_run(tmp_path / "run", rows([5.0]), CFG)
    before = (run / "samples.jsonl").read_bytes()
    with pytest.raises(
        InvalidInputError, match=r"already holds a run \(.*samples.jsonl.*\); pass a new --out, or add --force"
    ):
        write_run(run, rows([90.0, 90.0]), CFG)
    assert (run / "samples.jsonl").read_bytes() == before
    write_run(run, rows([90.0, 90.0]), CFG, force=True)
    assert len(read_rows(run / "samples.jsonl")) == 2
    (tmp_path / "file").write_text("x")
    with pytest.raises(InvalidInputError, match="is a file"):
        write_run(tmp_path / "file", rows([1.0]), CFG)
    (tmp_path / "empty").mkdir()
    write_run(tmp_path / "empty", rows([1.0]), CFG)  # an empty folder is fine


def _per_sample_csv(path: Path, run_rows: list[dict]) -> Path:
    lines = ["sample_id,R,t"]
    for r in run_rows:
        T = np.asarray(r["T_est"]).reshape(4, 4)
        lines.append(f"{r['sample_id']},{' '.join(map(str, T[:3, :3].ravel()))},{' '.join(map(str, T[:3, 3]))}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_score_never_writes_over_a_run(tmp_path, capsys):
    """Finding 1: score --out RUN deleted samples.jsonl of an existing run, even the --gt run."""
    gt = write_run(tmp_path / "gt", rows([5.0, 10.0]), CFG)
    preds = _per_sample_csv(tmp_path / "p.csv", rows([7.0, 9.0]))
    before = {p.name: p.read_bytes() for p in gt.iterdir()}
    for extra in ([], ["--force"]):
        assert bench(["score", str(preds), "--gt", str(gt), "--method", "ext", "--out", str(gt), *extra]) == 2
        assert "is the --gt run itself; pass another --out" in one_error_line(capsys, "score")
    assert {p.name: p.read_bytes() for p in gt.iterdir()} == before
    other = write_run(tmp_path / "other", rows([1.0]), CFG)
    assert bench(["score", str(preds), "--gt", str(gt), "--method", "ext", "--out", str(other)]) == 2
    assert "pass a new --out, or add --force" in one_error_line(capsys, "score")
    assert bench(["score", str(preds), "--gt", str(gt), "--method", "ext", "--out", str(other), "--force"]) == 0
    assert [r["method"] for r in read_rows(other / "samples.jsonl")] == ["ext", "ext"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary folder left
    (tmp_path / "afile").write_text("x")
    assert bench(["score", str(preds), "--gt", str(gt), "--method", "ext", "--out", str(tmp_path / "afile")]) == 2
    assert "is a file" in one_error_line(capsys, "score")


@pytest.mark.parametrize("command", ["score", "export"])
def test_a_full_disk_while_scoring_or_exporting_is_one_line_and_leaves_nothing(tmp_path, capsys, monkeypatch, command):
    gt_rows = rows([5.0, 10.0]) if command == "score" else with_bop_ids(rows([5.0, 10.0]))  # export: BOP ids
    gt = write_run(tmp_path / "gt", gt_rows, CFG)
    preds = _per_sample_csv(tmp_path / "p.csv", rows([7.0, 9.0]))
    before = sorted(p.name for p in tmp_path.iterdir())

    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")

    for move in ("replace", "link", "rename"):  # a new file is linked into place, a folder renamed
        monkeypatch.setattr(atomic.os, move, full)
    args = {
        "score": ["score", str(preds), "--gt", str(gt), "--method", "ext", "--out", str(tmp_path / "o")],
        "export": ["export", str(gt), "--out", str(tmp_path / "m_toy-test.csv")],
    }[command]
    assert bench(args) == 2
    assert "No space left on device); pass a" in one_error_line(capsys, command)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no half-written folder or file
