"""``bench suite real``: set and method tables, skipping, composition, the table format."""

from __future__ import annotations

from pathlib import Path

import pytest

from catpose.bench.real import suite as sr
from catpose.bench.real import suite_table as st
from catpose.errors import ConfigError


def test_every_set_and_method_composes(tmp_path):
    for s in sr.SETS.values():
        for v in sr.METHODS.values():
            cfg, overrides = sr.compose(s, v, tmp_path, 0, 2, str(tmp_path / "out"), ["method.selection=loss"])
            assert cfg.dataset.name == s.dataset and cfg.method.name == v.method and cfg.limit == 2
            assert str(cfg.dataset.root).startswith(str(tmp_path))
            if v.label.endswith("-dict"):
                assert cfg.method.matching == "dictionary"
            # ours-only overrides never reach the baselines
            assert ("method.selection=loss" in overrides) == (v.method == "ours")


def test_skips_absent_data_and_untracked_redwood(tmp_path):
    assert "absent" in sr.skip_reason(sr.SETS["ycbv"], tmp_path)
    (tmp_path / "redwood" / "chair_1" / "depth").mkdir(parents=True)
    assert "trajectory" in sr.skip_reason(sr.SETS["redwood"], tmp_path)
    (tmp_path / "redwood" / "chair_1" / "chair_1.log").write_text("")
    assert sr.skip_reason(sr.SETS["redwood"], tmp_path) is None


def test_main_skips_cleanly_without_shared_data(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(tmp_path / "nowhere"))
    assert sr.main(["real"]) == 0
    assert "skipped" in capsys.readouterr().out


def test_unknown_method_is_a_config_error(monkeypatch, tmp_path):
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(tmp_path))
    with pytest.raises(ConfigError, match="--methods"):
        sr.main(["real", "--methods", "ours,nope"])


def test_table_marks_the_best_and_lists_skips():
    row = dict(n=2, failed=0, mean_err_deg=10.0, median_err_deg=5.0, acc10=0.5, acc30=1.0, median_runtime_s=1.0)
    better = dict(row, mean_err_deg=2.0, acc10=1.0)
    table = st.format_table(
        {("ycbv", "ours"): better, ("ycbv", "icp"): row}, ["ycbv"], ["ours", "icp"], {"redwood": "no trajectory"}
    )
    lines = table.splitlines()
    assert lines[2].startswith("| ours | **2.00** / 5.00 / **1.000**")
    assert lines[3].startswith("| icp | 10.00 / 5.00 / 0.500")
    assert "skipped redwood: no trajectory" in table


def test_cli_lists_the_suite_command():
    from catpose.bench.cli import COMMANDS

    assert COMMANDS["suite"][0] == "catpose.bench.real.suite"


@pytest.mark.slow
def test_one_real_sample_runs_through_the_runner(shared_data, tmp_path, monkeypatch):
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(shared_data))
    results, skipped = sr.run_suite(
        ["ycbv"], ["icp"], Path(shared_data), seeds=(0,), limit=1, output_root=str(tmp_path), log=lambda m: None
    )
    r = results[("ycbv", "icp")]
    assert r["n"] == 1 and r["failed"] == 0 and Path(r["run_dir"], "samples.jsonl").is_file()
    assert len(r["samples"]) == 1


def test_sets_with_a_split_get_a_column_per_part():
    from catpose.bench.real.split import load_split
    from catpose.bench.real.suite_table import part_label

    ids = ["can/000001/000002/0", "bottle/000001/000004/1", "can/000002/000002/0"]
    split = load_split("ycbv")
    rows = [{"sample_id": i} for i in ids]
    assert split.row_ids("scene1", rows) == ids[:2] and split.row_ids("scene2", rows) == ids[2:]
    assert part_label("ycbv", split, "scene2") == "ycbv:scene2 (report A, choose B)"
    results = {("ycbv", "ours"): {}, (part_label("ycbv", split, "scene1"), "ours"): {}, ("tyol", "ours"): {}}
    assert sr.columns(results, ["ycbv", "tyol"]) == ["ycbv", part_label("ycbv", split, "scene1"), "tyol"]


def test_the_clutter_suite_loads_only_its_report_scenes(tmp_path):
    cfg, overrides = sr.compose(
        sr.CLUTTER_SETS["clutter"], sr.METHODS["ours"], tmp_path, 0, None, str(tmp_path / "out"), []
    )
    assert cfg.dataset.name == "clutter" and list(cfg.dataset.scenes) == list(range(100, 200))
    assert any(o.startswith("dataset.scenes=[100,") for o in overrides)


def test_a_method_without_its_extra_is_skipped_with_the_install_line(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "cv2", None)  # OpenCV's contrib build not installed
    monkeypatch.setitem(sys.modules, "cv2.ppf_match_3d", None)  # also when another test imported it
    assert "pip install -e '.[ppf]'" in sr.missing_extra(sr.METHODS["ppf"])
    assert sr.missing_extra(sr.METHODS["icp"]) is None
    lines: list[str] = []
    (tmp_path / "bop" / "tyol").mkdir(parents=True)  # a set that exists but has no frames: nothing runs
    results, skipped = sr.run_suite(["tyol"], ["ppf"], tmp_path, log=lines.append, table_only=True)
    assert results == {} and "ppf" not in skipped  # a table from run directories needs no extra
    results, skipped = sr.run_suite(["modelnet40_resampled"], ["ppf"], tmp_path, log=lines.append)
    assert "pip install" in skipped["ppf"] and any("skipping ppf" in line for line in lines)


def test_headline_holds_the_whole_sets_and_write_every_part(tmp_path, monkeypatch):
    row = dict(n=2, failed=0, mean_err_deg=3.0, median_err_deg=2.0, acc10=1.0, acc30=1.0, median_runtime_s=0.1)
    part = "ycbv:scene1 (choose A, report B)"
    fake = {("ycbv", "ours"): dict(row, ar=0.9, ar_vsd=0.8, ar_mssd=0.95, ar_mspd=0.95), (part, "ours"): row}
    monkeypatch.setattr(sr, "run_suite", lambda *a, **k: (fake, {}))
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(tmp_path))
    full, head = tmp_path / "table.md", tmp_path / "headline.md"
    assert sr.main(["real", "--sets", "ycbv", "--methods", "ours", "--write", str(full), "--headline", str(head)]) == 0
    assert part in full.read_text() and part not in head.read_text()
    assert (
        head.read_text().splitlines()[0]
        == "| method | ycbv: mean / med / @10 / found@10 / @30 (s) | ycbv: AR (VSD / MSSD / MSPD) |"
    )
    assert "**0.900** (0.800 / 0.950 / 0.950)" in head.read_text()


ROW = dict(n=2, failed=0, mean_err_deg=10.0, median_err_deg=5.0, acc10=0.5, acc30=1.0, median_runtime_s=1.0)


def test_a_cell_is_the_mean_over_seeds_with_their_spread():
    seeds = [
        dict(ROW, mean_err_deg=m, acc10=a, samples=frozenset({(s, "x"), (s, "y")}))
        for s, (m, a) in enumerate([(2.0, 1.0), (4.0, 0.5), (180.0, 0.0)])
    ]
    cell = st.pool_seeds(seeds)
    assert cell["mean_err_deg"] == pytest.approx(62.0) and cell["spread"]["acc10"] == (0.0, 1.0)
    assert cell["n"] == 2 and cell["seeds"] == 3 and len(cell["samples"]) == 6
    table = st.format_table({("tyol", "ours"): cell}, ["tyol"], ["ours"], {}, [st.seeds_note((0, 1, 2))])
    assert (
        "| ours | **62.00** [2.00-180.00] / 5.00 / **0.500** [0.000-1.000] / - / 1.000 (1.00) n=2 x 3 seeds |" in table
    )
    assert "the mean over seeds 0, 1, 2" in table


def _planted(deg: float, about: str = "x", axis=None, status: str = "ok", truth_deg: float = 0.0) -> dict:
    """A ``samples.jsonl`` row whose truth is turned ``truth_deg`` degrees about y and its estimate
    ``deg`` degrees about ``about`` from there."""
    from scipy.spatial.transform import Rotation

    def T(R) -> list[float]:
        return [v for r in R.as_matrix().tolist() for v in [*r, 0.0]] + [0.0, 0.0, 0.0, 1.0]

    truth = Rotation.from_euler("y", truth_deg, degrees=True)
    estimate = Rotation.from_euler(about, deg, degrees=True) * truth
    return dict(status=status, T_est=T(estimate), T_gt=T(truth), symmetry_axis=axis, symmetries=None)


def test_seed_agreement_counts_samples_whose_estimates_lie_within_10_deg_under_every_seed():
    up = [0.0, 0.0, 1.0]
    per_seed = [  # four samples under three seeds
        {"same": _planted(0), "apart": _planted(0), "spin": _planted(0, "z", up), "flip": _planted(0, "x", up)},
        {"same": _planted(4), "apart": _planted(9), "spin": _planted(120, "z", up), "flip": _planted(178, "x", up)},
        {"same": _planted(8), "apart": _planted(18), "spin": _planted(240, "z", up), "flip": _planted(0, "x", up)},
    ]
    estimates = [{i: st.estimate(r) for i, r in seed.items()} for seed in per_seed]
    # same: pairwise <= 8 deg; apart: 0 and 18 are 18 deg apart though each is within 10 of 9; spin: a
    # turn about a symmetric object's main axis moves no axis; flip: that axis turned over under one seed
    assert st.seed_agreement(estimates) == pytest.approx(2 / 4)
    estimates[1]["same"] = st.estimate(_planted(4, status="failed"))  # a failed answer never agrees
    assert st.seed_agreement(estimates) == pytest.approx(1 / 4)
    del estimates[2]["spin"]  # only the samples every seed answered are counted
    assert st.seed_agreement(estimates) == 0.0
    # seeds that draw another view of a sample: the same error from each view's truth agrees
    views = [{"v": st.estimate(_planted(90, "x", truth_deg=t))} for t in (0.0, 40.0, 80.0)]
    assert st.seed_agreement(views) == 1.0
    cell = st.pool_seeds([dict(ROW, samples=frozenset(), estimates=e) for e in estimates])
    table = st.format_table({("tyol", "ours"): cell}, ["tyol"], ["ours"], {}, [st.seeds_note((0, 1, 2))])
    assert "n=2 x 3 seeds, agree 0.00 |" in table and "agree: the fraction of samples" in table


def test_a_column_of_different_samples_is_refused_unless_allowed(tmp_path, monkeypatch, capsys):
    from catpose.bench.cli import main

    full = dict(ROW, samples=frozenset({(0, "a"), (0, "b")}), run_dir="runs/ours")
    part = dict(ROW, samples=frozenset({(0, "a")}), run_dir="runs/icp")
    assert st.mixed_samples({("ycbv", "ours"): full, ("ycbv", "icp"): full}, ["ycbv"], ["ours", "icp"]) is None
    monkeypatch.setattr(sr, "run_suite", lambda *a, **k: ({("ycbv", "ours"): full, ("ycbv", "icp"): part}, {}))
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(tmp_path))
    assert main(["suite", "real", "--sets", "ycbv", "--methods", "ours,icp"]) == 2
    err = capsys.readouterr().err
    assert "column ycbv compares different samples: ours (runs/ours) has 2, icp (runs/icp) 1" in err
    assert err.count("\n") == 1
    assert main(["suite", "real", "--sets", "ycbv", "--methods", "ours,icp", "--allow-mixed"]) == 0
    assert "Mixed (--allow-mixed): column ycbv" in capsys.readouterr().out


def test_the_ycbv_protocol_sets_compose(tmp_path):
    t = sr.SETS["ycbv_templates"]
    cfg, _ = sr.compose(t, sr.METHODS["ours"], tmp_path, 1, None, str(tmp_path / "out"), [])
    assert cfg.protocol.name == "templates" and list(cfg.dataset.symmetric.can) == [0, 0, 1] and cfg.seed == 1
    cfg, _ = sr.compose(sr.SETS["ycbv_relative"], sr.METHODS["icp"], tmp_path, 0, None, str(tmp_path / "out"), [])
    assert cfg.protocol.name == "relative" and cfg.dataset.name == "ycbv"
