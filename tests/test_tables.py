"""Paper tables from frozen run directories: golden statistics, layouts, best/second marks."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from catpose.bench.report import table_command, tables
from catpose.bench.report.labels import pipeline_label
from catpose.bench.report.runs import load_run
from catpose.errors import ConfigError, DatasetError
from catpose.geometry import axis_angle_to_R, make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import write_run  # noqa: E402

GT_MODEL = {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"}
SCORE = {"name": "score", "rule": "score"}  # the choice group: read by a templates run only
TEMPLATES = {"name": "templates", "_target_": "catpose.bench.protocols.absolute.Templates", "max_templates": None}


def rows_with_errors(
    errors: dict[str, list[float | None]],
    method: str,
    protocol: str = "gt_model",
    templates: int = 1,
    trans: float = 0.1,
) -> list[dict]:
    """One row per (category, view, template): the estimate is the truth rotated by the error
    about x (err None: failed); template k > 0 adds 10*k degrees and a higher score."""
    rows = []
    for cat, errs in errors.items():
        for i, e in enumerate(errs):
            obs = f"{cat}/i{i}/v0"
            for k in range(templates):
                sid = obs if templates == 1 and protocol == "gt_model" else f"{obs}|{k}"
                T_gt = make_T(np.eye(3), np.array([0.0, 0.0, 2.0]))
                row = {
                    "sample_id": sid,
                    "group_id": obs,
                    "obs_id": obs,
                    "category": cat,
                    "instance_id": f"i{i}",
                    "template_id": f"t{k}",
                    "method": method,
                    "dataset": "toy",
                    "protocol": protocol,
                    "seed": 0,
                    "symmetric": False,
                    "symmetry_axis": None,
                    "T_gt": T_gt.reshape(-1).tolist(),
                    "runtime_s": 0.5,
                    "info": {},
                    "extras": {},
                }
                if e is None:
                    row.update(status="failed", error="boom", stage="register", err_deg=180.0, T_est=None, score=None)
                else:
                    ang = e + 10.0 * k
                    T_est = make_T(axis_angle_to_R(np.array([1.0, 0, 0]), np.radians(ang)), np.array([trans, 0, 2.0]))
                    row.update(
                        status="ok",
                        error="",
                        stage="",
                        T_est=T_est.reshape(-1).tolist(),
                        score=float(k),
                        err_deg=ang,
                        rot_err_deg=ang,
                        axis_err_deg=None,
                        trans_err=trans,
                    )
                rows.append(row)
    return rows


def make_run(root: Path, name: str, errors: dict, method_cfg: dict, protocol: dict = GT_MODEL, **kw) -> Path:
    rows = rows_with_errors(errors, method_cfg["name"], protocol["name"], **kw)
    cfg = {
        "method": dict(method_cfg, _target_="x.Y"),
        "dataset": {"name": "toy"},
        "protocol": protocol,
        "choice": SCORE,
        "seed": 0,
    }
    return write_run(root / name, rows, cfg)


@pytest.fixture()
def runs(tmp_path: Path) -> list[Path]:
    a = make_run(
        tmp_path,
        "ours",
        {"airplane": [1, 2, 3, 40], "chair": [5, 50, None]},
        {"name": "ours", "matching": "dictionary", "descriptor": "lps"},
        trans=0.1,
    )
    b = make_run(
        tmp_path,
        "fgr",
        {"airplane": [10, 20, 30, 40], "chair": [4, 60, 70]},
        {"name": "fgr", "matching": "direct", "descriptor": "fpfh"},
        trans=0.3,
    )
    c = make_run(
        tmp_path, "icp", {"airplane": [0.5, 100, 120, 150], "chair": [90, 100, 110]}, {"name": "icp"}, trans=0.2
    )
    return [a, b, c]


def test_golden_statistics(runs):
    """Statistics recomputed from the frozen poses (the stored err_deg is not trusted)."""
    run = load_run(runs[0])
    assert run.samples["err_deg"].tolist()[:4] == pytest.approx([1, 2, 3, 40], abs=1e-4)
    entries = tables.collect([run], pipeline_label)
    s = entries[0].summary
    assert entries[0].group == "Dictionary LPS" and entries[0].label == "Ours"
    assert s.loc["airplane", "mean_err_deg"] == pytest.approx(11.5, abs=1e-4)
    assert s.loc["airplane", "median_err_deg"] == pytest.approx(2.5, abs=1e-4)
    assert s.loc["airplane", "acc10"] == pytest.approx(0.75)
    assert s.loc["chair", "mean_err_deg"] == pytest.approx((5 + 50 + 180) / 3, abs=1e-4)
    assert s.loc["chair", "failed"] == 1 and s.loc["chair", "acc30"] == pytest.approx(1 / 3)
    assert s.loc["chair", "mean_trans_err"] == pytest.approx(0.1)


def test_optimiser_layout_marks_best_and_second(runs):
    t = tables.build_table([load_run(p) for p in runs], "optimiser")
    assert [r for r in t.rows] == [("-", "ICP"), ("Direct match FPFH", "FGR"), ("Dictionary LPS", "Ours")]
    assert ("Airplane", "Mean° ↓") in t.columns and ("Chair", "L_T ↓") in t.columns
    ranks = t.ranks()
    # Airplane mean: ours 11.5 (best), fgr 25 (second), icp 92.625
    assert ranks[(("Dictionary LPS", "Ours"), ("Airplane", "Mean° ↓"))] == 1
    assert ranks[(("Direct match FPFH", "FGR"), ("Airplane", "Mean° ↓"))] == 2
    assert (("-", "ICP"), ("Airplane", "Mean° ↓")) not in ranks
    md = tables.to_markdown(t)
    assert "**11.500**" in md and "<u>25.000</u>" in md and "92.625" in md
    tex = tables.to_latex(t)
    assert r"\textbf{11.500}" in tex and r"\underline{25.000}" in tex and r"\multicolumn{3}{c}{Airplane}" in tex
    csv = tables.to_csv(t).splitlines()
    assert csv[0].startswith("Pipeline / Descriptor,Methods,Airplane/Mean° ↓")
    fields = csv[3].split(",")
    assert fields[:2] == ["Dictionary LPS", "Ours"] and float(fields[2]) == pytest.approx(11.5, abs=1e-6)


def test_higher_is_better_columns(runs):
    t = tables.build_table([load_run(p) for p in runs], "one_template")
    ranks = t.ranks()
    # @10 airplane: ours 0.75 (best), icp 0.25 and fgr 0.25 tie for second
    col = ("Airplane", "@10 ↑")
    assert ranks[(("Dictionary LPS", "Ours"), col)] == 1
    assert ranks[(("-", "ICP"), col)] == 2 and ranks[(("Direct match FPFH", "FGR"), col)] == 2


def test_real_and_tyol_layouts(runs):
    loaded = [load_run(p) for p in runs]
    real = tables.build_table(loaded, "real", categories=["airplane", "chair"])
    assert real.columns == [("FGR",), ("ICP",), ("Ours",)] and real.rank_by == "row"
    # chair medians: ours 50, fgr 60, icp 100 -> ranked across methods within the row
    assert real.ranks()[(("Chair", "Med.° ↓"), ("Ours",))] == 1
    assert real.ranks()[(("Chair", "Med.° ↓"), ("FGR",))] == 2
    ty = tables.build_table(loaded, "tyol", categories=["chair"])
    assert ("Ours", "Mean° ↓") in ty.rows and ty.columns == [("Chair",)]
    assert "Mean$^{\\circ}\\downarrow$" in tables.to_latex(ty)


def test_templates_layout_uses_oracle(tmp_path: Path):
    one = make_run(tmp_path, "ours1", {"chair": [20, 40]}, {"name": "ours"}, TEMPLATES, templates=1)
    five = make_run(tmp_path, "ours5", {"chair": [20, 40]}, {"name": "ours"}, TEMPLATES, templates=5)
    t = tables.build_table([load_run(one), load_run(five)], "templates")
    assert t.rows == [("1", "Ours"), ("5", "Ours")]
    assert t.cells[(("5", "Ours"), ("Chair", "Mean° ↓"))][0] == pytest.approx(30.0, abs=1e-4)
    assert any("oracle" in n for n in t.notes)


def test_ablation_labels(tmp_path: Path):
    a = make_run(tmp_path, "full", {"airplane": [1.0]}, {"name": "ours", "optimiser": {"mode": "joint"}})
    b = make_run(tmp_path, "svd", {"airplane": [9.0]}, {"name": "ours", "optimiser": {"mode": "none"}})
    t = tables.build_table([load_run(a), load_run(b)], "ablation")
    assert [r[1] for r in t.rows] == ["Ours", "Ours (w/o optimization)"]
    assert t.rows[0][0] == "gt_model Dictionary"  # ours always matches against the dictionary


def test_cli_writes_file_and_user_labels(runs, tmp_path: Path, capsys):
    out = tmp_path / "t.tex"
    assert (
        table_command.main(
            [
                str(runs[0].parent),
                "--layout",
                "generic",
                "--format",
                "latex",
                "--out",
                str(out),
                "--label",
                f"{runs[2]}=ICP (20 starts)",
                "--metrics",
                "mean,median",
            ]
        )
        == 0
    )
    text = out.read_text()
    assert "ICP (20 starts)" in text and "All" in text
    from catpose.bench.cli import main

    assert main(["table", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bench table: error: ") and "does not exist" in err and err.count("\n") == 1
    with pytest.raises(ConfigError):
        tables.build_table([load_run(runs[0])], "nope")
    with pytest.raises(DatasetError):
        load_run(tmp_path)


def test_truncated_jsonl_line_is_skipped_as_by_the_runner(tmp_path: Path):
    # a killed run leaves a partial last line: tables read it as `bench run` resumes it
    (tmp_path / "samples.jsonl").write_text('{"sample_id": "a"}\n{"sample_id": "a", "sta\n')
    assert load_run(tmp_path).samples["sample_id"].tolist() == ["a"]


def test_rows_without_shown_categories_are_dropped(runs, tmp_path: Path):
    only_car = make_run(tmp_path, "car_only", {"car": [3.0]}, {"name": "teaser"})
    t = tables.build_table([load_run(p) for p in [*runs, only_car]], "optimiser", categories=["airplane"])
    assert ("-", "TEASER (re-impl.)") not in t.rows and len(t.rows) == 3
    assert any("TEASER (re-impl.)" in n for n in t.notes)


def test_errors_come_from_poses_not_stored_numbers(runs):
    import json

    path = runs[0] / "samples.jsonl"
    rows = [json.loads(x) for x in path.read_text().splitlines()]
    for r in rows:
        r["err_deg"] = 999.0 if r["status"] == "ok" else r["err_deg"]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    s = load_run(runs[0]).samples
    assert s.loc[s["status"] == "ok", "err_deg"].max() < 100.0


def test_a_label_that_names_no_run_is_an_error_not_dropped(runs, capsys):
    from catpose.bench.cli import main

    # the item splits at its last "=": "<run>=ICP: a" would name no run, and the label was lost
    assert main(["table", str(runs[0].parent), "--label", f"{runs[2]}=ICP: a=b"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bench table: error: --label ") and "none of the runs" in err and err.count("\n") == 1
    assert main(["table", str(runs[0].parent), "--label", f"{runs[2].name}=ICP by name"]) == 0
    assert "ICP by name" in capsys.readouterr().out
