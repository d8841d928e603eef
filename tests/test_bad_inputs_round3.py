"""Issue 60, "files and numbers you can trust, round 3": one test per numbered case, named after it.

Each case runs on toy runs and files made here (no shared data), in-process, in about a second.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from catpose.bench.cli import main as bench
from catpose.bench.run.rundir import read_rows, write_run

TESTS = Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))

from _trust import CFG, one_error_line, rows  # noqa: E402
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
    from catpose.bench.run.lock import RunLock

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


def test_case_04_no_run_inside_a_run_and_no_force_over_runs_below(tmp_path, capsys):
    outer = write_run(tmp_path / "outer", rows([5.0]), CFG)
    assert bench(["run", "method=icp", "dataset=synthetic", "limit=1", f"hydra.run.dir={outer / 'inner'}"]) == 2
    assert "lies inside the run directory" in one_error_line(capsys, "run")
    assert not (outer / "inner").exists()
    (outer / "inner").mkdir()  # made by hand (no command makes it)
    (outer / "inner/samples.jsonl").write_bytes((outer / "samples.jsonl").read_bytes())
    gt = write_run(tmp_path / "gt", rows([5.0]), CFG)
    preds = per_sample_csv(tmp_path / "p.csv", rows([7.0]))
    before = snapshot(outer)
    assert _score(preds, gt, outer, "--force") == 2
    assert "holds run directories below it" in one_error_line(capsys, "score")
    assert snapshot(outer) == before


# ---------------------------------------------------------------------------------------------
# tracebacks


def test_case_17_18_hydra_run_dir_read_only_or_a_file_is_one_line(tmp_path, capsys, monkeypatch):
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert bench(["run", "method=icp", "dataset=synthetic", "limit=1", f"hydra.run.dir={afile}"]) == 2
    assert "is a file, not a folder" in one_error_line(capsys, "run")
    ro = tmp_path / "ro"
    ro.mkdir()
    access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: Path(p) != ro and access(p, mode))  # root writes anywhere
    assert bench(["run", "method=icp", "dataset=synthetic", "limit=1", f"hydra.run.dir={ro / 'r'}"]) == 2
    assert "is not writable" in one_error_line(capsys, "run")
