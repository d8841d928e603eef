"""Tables that compare only what compares (catpose.bench.report.tables_compare): rows of other
datasets, protocols, seeds or sample sets are refused in one line, ``--allow-mixed`` says so in a
note; the seeds of one configuration are one row with their spread; a subset run has its own
directory."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from catpose.bench.report import tables
from catpose.bench.report.runs import load_run
from catpose.errors import DatasetError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import write_run  # noqa: E402

TESTS = Path(__file__).resolve().parent


@pytest.fixture()
def rows_with_errors(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    from test_tables import rows_with_errors

    return rows_with_errors


@pytest.fixture()
def make(tmp_path: Path, rows_with_errors):
    def make(name: str, method: str, errors: dict, seed: int = 0, dataset: str = "toy", **run_keys) -> Path:
        rows = [dict(r, seed=seed, dataset=dataset) for r in rows_with_errors(errors, method)]
        cfg = {
            "method": {"name": method, "_target_": "x.Y"},
            "dataset": {"name": dataset, "seed": seed},
            "protocol": {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"},
            "seed": seed,
            **run_keys,
        }
        return write_run(tmp_path / name, rows, cfg)

    return make


FULL = {"chair": [1.0, 2.0, 3.0, 40.0, 50.0, 60.0]}
FIRST4 = {"chair": [10.0, 20.0, 30.0, 40.0]}


def test_a_limit_run_beside_a_full_run_is_refused_in_one_line_naming_both(make, capsys):
    from catpose.bench.cli import main

    full = make("ours_full", "ours", FULL)
    part = make("icp_limit4", "icp", FIRST4, limit=4)
    with pytest.raises(DatasetError, match="samples: 4 vs 6") as e:
        tables.build_table([load_run(full), load_run(part)])
    assert str(full) in str(e.value) and str(part) in str(e.value) and "\n" not in str(e.value)
    assert main(["table", str(full), str(part)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bench table: error: rows of different samples") and err.count("\n") == 1
    assert main(["table", str(full), str(part), "--allow-mixed"]) == 0
    out = capsys.readouterr().out
    assert "Mixed (--allow-mixed): rows of different samples" in out
    assert "n (scored units): ICP 4 (seed 0); Ours 6 (seed 0)." in out


def test_two_datasets_are_two_rows_and_refused(make, capsys):
    from catpose.bench.cli import main

    syn = make("icp_synthetic", "icp", {"chair": [1.0, 2.0]}, dataset="synthetic")
    ycbv = make("icp_ycbv", "icp", {"mug": [5.0, 6.0]}, dataset="ycbv")
    assert main(["table", str(syn), str(ycbv)]) == 2
    err = capsys.readouterr().err
    assert "differ in dataset synthetic vs ycbv" in err and err.count("\n") == 1
    t = tables.build_table([load_run(syn), load_run(ycbv)], allow_mixed=True)
    assert t.rows == [("ICP (synthetic)",), ("ICP (ycbv)",)]  # never pooled into one row
    assert any(n.startswith("Mixed (--allow-mixed)") for n in t.notes)


def test_the_seeds_of_one_config_are_one_row_with_their_spread(make):
    a = [make(f"ours_s{s}", "ours", {"chair": [float(s + 1)] * 3}, seed=s) for s in (0, 1, 2)]
    b = [make(f"icp_s{s}", "icp", {"chair": [10.0 * (s + 1)] * 3}, seed=s) for s in (0, 1, 2)]
    t = tables.build_table([load_run(p) for p in a + b], metrics=["mean"])
    assert t.rows == [("ICP",), ("Ours",)]
    cell = (("Ours",), ("Chair", "Mean° ↓"))
    assert t.cells[cell][0] == pytest.approx(2.0, abs=1e-4) and t.spread[cell] == pytest.approx((1.0, 3.0), abs=1e-4)
    md = tables.to_markdown(t)
    assert "**2.000 [1.000, 3.000]**" in md and "20.000 [10.000, 30.000]" in md
    assert "Ours 3 x 3 seeds (0, 1, 2)" in md and "the mean across seeds [their min, max]" in md
    with pytest.raises(DatasetError, match="differ in seeds 0 vs 0, 1, 2"):  # all of ours' seeds beside one of ICP's
        tables.build_table([load_run(p) for p in a + b[:1]])


def test_the_report_refuses_mixed_samples_unless_allowed(make, tmp_path: Path, capsys):
    from catpose.bench.cli import main

    full = make("ours_full", "ours", FULL)
    part = make("icp_limit4", "icp", FIRST4, limit=4)
    args = ["report", str(full), str(part), "--no-pictures", "--no-pdf"]
    assert main([*args, "--out", str(tmp_path / "r1")]) == 2
    assert "rows of different samples" in capsys.readouterr().err and not (tmp_path / "r1").exists()
    assert main([*args, "--out", str(tmp_path / "r2"), "--allow-mixed"]) == 0
    assert "Mixed (--allow-mixed)" in (tmp_path / "r2" / "index.md").read_text()


def test_a_subset_of_the_samples_has_its_own_run_directory(tmp_path: Path):
    from catpose.bench.run import config
    from catpose.bench.run.rundir import run_dir_for

    def where(*extra: str) -> Path:
        overrides = ["method=icp", "dataset=synthetic", f"output_root={tmp_path}", *extra]
        return run_dir_for(config.compose(overrides), overrides)

    full = where()
    assert where("limit=null") == full and where("progress=false") == full
    limited, listed = where("limit=4"), where("sample_ids=[chair/000/v00]")
    assert len({full, limited, listed}) == 3 and limited.name.startswith("seed0-limit=4-")
