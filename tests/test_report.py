"""The report folder: unique hash-free labels, per-protocol tables, relative links only, and the
pictures of each run's worst registration."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from catpose.bench.report import tables
from catpose.bench.report.labels import parse_labels, run_labels
from catpose.bench.report.report_folder import build_report, worst_drawable
from catpose.bench.report.report_folder import main as report_main
from catpose.bench.report.runs import load_run
from catpose.errors import DatasetError
from catpose.geometry import axis_angle_to_R, make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import write_run  # noqa: E402

GT_MODEL = {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"}
SCORE = {"name": "score", "rule": "score"}  # the choice group: read by a templates run only
TEMPLATES = {"name": "templates", "_target_": "catpose.bench.protocols.absolute.Templates", "max_templates": None}
HASH = re.compile(r"\b[0-9a-f]{8}\b")


def _rows(errors: dict[str, list[float]], method: str, protocol: str) -> list[dict]:
    rows = []
    for cat, errs in errors.items():
        for i, e in enumerate(errs):
            obs = f"{cat}/{i:03d}/v00"
            T_gt = make_T(np.eye(3), np.array([0.0, 0.0, 2.0]))
            T_est = make_T(axis_angle_to_R(np.array([1.0, 0, 0]), np.radians(e)), np.array([0.0, 0.0, 2.0]))
            rows.append(
                {
                    "sample_id": obs if protocol == "gt_model" else f"{obs}|0",
                    "group_id": obs,
                    "obs_id": obs,
                    "category": cat,
                    "instance_id": f"{i:03d}",
                    "template_id": "t0",
                    "method": method,
                    "status": "ok",
                    "error": "",
                    "err_deg": e,
                    "rot_err_deg": e,
                    "trans_err": 0.0,
                    "T_est": T_est.reshape(-1).tolist(),
                    "T_gt": T_gt.reshape(-1).tolist(),
                    "symmetric": False,
                    "symmetry_axis": None,
                    "score": 0.0,
                    "runtime_s": 0.1 * (i + 1),
                    "info": {},
                    "extras": {},
                }
            )
    return rows


def _run(
    root: Path,
    name: str,
    method: dict,
    protocol: dict = GT_MODEL,
    errors: dict | None = None,
    overrides: list[str] | None = None,
) -> Path:
    """A frozen run directory named like the runner's (``<tag>-<hash>``), with its overrides file."""
    errors = errors or {"airplane": [1.0, 2.0, 40.0], "chair": [0.5, 90.0]}
    cfg = {
        "method": dict(method, _target_="x.Y"),
        "dataset": {"name": "toy"},
        "protocol": protocol,
        "choice": SCORE,
        "seed": 0,
    }
    out = write_run(
        root / f"toy-{protocol['name']}" / method["name"] / name, _rows(errors, method["name"], protocol["name"]), cfg
    )
    if overrides is not None:
        (out / "overrides.txt").write_text(
            "\n".join(["dataset=toy", "seed=0", "output_root=/abs/out", f"method={method['name']}"] + overrides) + "\n"
        )
    return out


def test_labels_unique_by_the_distinguishing_override(tmp_path: Path):
    a = _run(tmp_path, "seed0-default-1a2b3c4d", {"name": "ours", "descriptor": "lps"}, overrides=[])
    b = _run(
        tmp_path,
        "seed0-method.descriptor=pfh-5e6f7a8b",
        {"name": "ours", "descriptor": "pfh"},
        overrides=["method.descriptor=pfh"],
    )
    c = _run(tmp_path, "seed0-default-9c0d1e2f", {"name": "icp"}, overrides=[])
    runs = [load_run(p) for p in (a, b, c)]
    assert run_labels(runs) == ["Ours", "Ours (descriptor=pfh)", "ICP"]
    t = tables.build_table(runs, "generic")
    assert sorted(r[-1] for r in t.rows) == ["ICP", "Ours", "Ours (descriptor=pfh)"]


def test_labels_from_config_differences_then_protocol(tmp_path: Path):
    a = _run(tmp_path, "seed0-x-1a2b3c4d", {"name": "icp", "max_iter": 30})
    b = _run(tmp_path, "seed0-y-5e6f7a8b", {"name": "icp", "max_iter": 100})
    c = _run(tmp_path, "seed0-default-9c0d1e2f", {"name": "icp", "max_iter": 30}, TEMPLATES)
    labels = run_labels([load_run(p) for p in (a, b)])
    assert labels == ["ICP (max_iter=30)", "ICP (max_iter=100)"]
    labels = run_labels([load_run(p) for p in (a, c)])
    assert labels == ["ICP (gt_model)", "ICP (templates)"]
    assert not any(HASH.search(x) for x in labels)


def test_labels_hash_only_when_nothing_else_differs(tmp_path: Path):
    a = _run(tmp_path, "seed0-default-1a2b3c4d", {"name": "icp"})
    b = _run(tmp_path / "again", "seed0-default-5e6f7a8b", {"name": "icp"})
    labels = run_labels([load_run(p) for p in (a, b)])
    assert len(set(labels)) == 2 and all(HASH.search(x) for x in labels)


def test_labels_pool_one_run_per_category(tmp_path: Path):
    a = _run(tmp_path, "chair", {"name": "ours"}, errors={"chair": [1.0]})
    b = _run(tmp_path, "car", {"name": "ours"}, errors={"car": [2.0]})
    assert run_labels([load_run(p) for p in (a, b)]) == ["Ours", "Ours"]


def _picks_units(errors: list[float | None]) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "sample_id": [f"s{i}" for i in range(len(errors))],
            "status": ["ok" if e is not None else "failed" for e in errors],
            "err_deg": [180.0 if e is None else e for e in errors],
            "T_est": [[0.0] if e is not None else None for e in errors],
        }
    )


def test_the_worst_drawable_unit_is_pictured():
    #                            s0   s1    s2   s3    s4   s5 (failed: no estimate to draw)
    assert worst_drawable(_picks_units([1.0, 35.0, 3.0, 150.0, 12.0, None])) == "s3"
    assert worst_drawable(_picks_units([None])) is None


def _links(text: str) -> list[str]:
    return re.findall(r"\]\(([^)]+)\)", text) + re.findall(r'(?:src|href)="([^"]+)"', text)


def test_report_per_protocol_relative_links(tmp_path: Path):
    _runs = [
        _run(tmp_path / "runs", "seed0-default-1a2b3c4d", {"name": "ours"}, overrides=[]),
        _run(
            tmp_path / "runs",
            "seed0-method.descriptor=pfh-5e6f7a8b",
            {"name": "ours", "descriptor": "pfh"},
            overrides=["method.descriptor=pfh"],
        ),
        _run(tmp_path / "runs", "seed0-default-9c0d1e2f", {"name": "icp"}, TEMPLATES, overrides=["protocol=templates"]),
        _run(
            tmp_path / "runs", "seed0-default-0a0b0c0d", {"name": "ours"}, TEMPLATES, overrides=["protocol=templates"]
        ),
    ]
    out = tmp_path / "report"
    index = build_report([tmp_path / "runs"], out, notes=["Made by the test."])
    md = index.read_text()
    assert str(tmp_path) not in md and "/abs/" not in md
    for link in _links(md):
        assert not link.startswith("/") and "://" not in link, link
        assert (out / link).is_file(), link
    for protocol in ("gt_model", "templates"):
        for stem in ("summary", "per_category"):
            assert f"tables/{protocol}_{stem}.md" in md
        for fig in ("error_cdf", "accuracy"):
            assert f"figures/{protocol}_{fig}.png" in md and (out / "figures" / f"{protocol}_{fig}.csv").is_file()
    # Each table holds one protocol's runs, with hash-free unique labels.
    gt = (out / "tables" / "gt_model_summary.csv").read_text().splitlines()
    assert [line.split(",")[0] for line in gt[1:]] == ["Ours", "Ours (descriptor=pfh)"]
    tpl = (out / "tables" / "templates_per_category.md").read_text()
    assert "ICP" in tpl and "pfh" not in tpl
    assert len(gt[0].split(",")) <= 10  # methods + 7 pooled metrics, not categories x metrics
    # Hashes only in the list of run directories, nowhere in tables, legends or captions.
    assert "Made by the test." in md and not HASH.search(md[md.index("## Protocol") :])
    for csv in (out / "figures").glob("*.csv"):
        assert not HASH.search(csv.read_text().split("\n", 1)[1].split(",")[0]), csv
    from catpose.bench.cli import main

    assert main(["report", str(tmp_path / "missing"), "--out", str(tmp_path / "r2")]) == 2
    with pytest.raises(DatasetError, match="missing does not exist"):
        report_main([str(tmp_path / "missing"), "--out", str(tmp_path / "r2")])


@pytest.mark.slow
def test_report_pictures_from_synthetic_run(tmp_path: Path):
    """The examples are rebuilt from the run's config (one rendered synthetic mug view, 2 views)."""
    from catpose.datasets.synthetic import SyntheticDataset

    ds_cfg = {
        "name": "synthetic",
        "_target_": "catpose.datasets.synthetic.SyntheticDataset",
        "seed": 0,
        "categories": ["mug"],
        "instances_per_category": 1,
        "views_per_instance": 3,
        "num_templates": 1,
        "template_points": 512,
    }
    ds = SyntheticDataset(**{k: v for k, v in ds_cfg.items() if k not in ("name", "_target_")})  # no option group
    rows = []
    for k, obs_id in enumerate(ds.observation_ids()):
        T_gt = np.asarray(ds.observation(obs_id).T_object_camera, float)
        T_est = make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(40 * k)), np.zeros(3)) @ T_gt
        rows.append(
            {
                "sample_id": obs_id,
                "group_id": obs_id,
                "obs_id": obs_id,
                "category": "mug",
                "instance_id": "000",
                "method": "ours",
                "status": "ok",
                "error": "",
                "err_deg": 40.0 * k,
                "rot_err_deg": 40.0 * k,
                "trans_err": 0.0,
                "T_est": T_est.reshape(-1).tolist(),
                "T_gt": T_gt.reshape(-1).tolist(),
                "symmetry_axis": None,
                "score": 0.1,
                "runtime_s": 0.2,
                "info": {},
                "extras": {},
            }
        )
    cfg = {"method": {"name": "ours", "_target_": "x.Y"}, "dataset": ds_cfg, "protocol": GT_MODEL, "seed": 0}
    run = write_run(tmp_path / "run_ours", rows, cfg)
    index = build_report([run], tmp_path / "report", pictures=True, pdf=False)
    md = index.read_text()
    ids = list(ds.observation_ids())
    assert f"worst: `{ids[2]}`, 80.0 deg" in md
    assert "not drawn" not in md
    for link in _links(md):
        assert (tmp_path / "report" / link).is_file(), link
    assert not list((tmp_path / "report" / "figures").glob("*.pdf"))


def test_pictures_are_on_by_default(monkeypatch, tmp_path: Path):
    from catpose.bench.report import report_folder

    seen = {}
    monkeypatch.setattr(report_folder, "build_report", lambda *a, **k: seen.update(args=a, kw=k) or tmp_path / "i.md")
    assert report_main(["some/run", "--out", str(tmp_path / "r")]) == 0
    assert seen["args"][2] is True
    report_main(["some/run", "--out", str(tmp_path / "r"), "--no-pictures"])
    assert seen["args"][2] is False


def test_a_user_label_is_kept_beside_other_runs_of_the_method(tmp_path: Path):
    """make_results.sh labels the row=ours run "Ours" beside other runs of ours: the label stays
    "Ours" (it was "Ours (row=ours)"), the others are told apart from it."""
    a = _run(tmp_path, "seed0-+row=ours-1a2b3c4d", {"name": "ours"}, overrides=["+row=ours"])
    b = _run(
        tmp_path, "seed0-+row=ours_pfh-5e6f7a8b", {"name": "ours", "descriptor": "pfh"}, overrides=["+row=ours_pfh"]
    )
    runs = [load_run(p) for p in (a, b)]
    assert run_labels(runs, parse_labels([f"{a}=Ours"])) == ["Ours", "Ours (row=ours_pfh)"]


def test_report_index_links_every_file_and_a_second_report_replaces_the_folder_whole(tmp_path: Path):
    runs = tmp_path / "runs"
    a = _run(runs, "seed0-default-1a2b3c4d", {"name": "ours"}, overrides=[])
    b = _run(runs, "seed0-default-9c0d1e2f", {"name": "icp"}, TEMPLATES, overrides=["protocol=templates"])
    out = tmp_path / "report"
    build_report([a, b], out, pictures=False)
    assert (out / "figures" / "templates_accuracy.png").is_file()
    (out / "notes.txt").write_text("mine")
    index = build_report([a], out, pictures=False, pdf=False)  # a second report (bench report --force), gt_model only
    assert not (out / "figures" / "templates_accuracy.png").exists() and not list(out.glob("figures/*.pdf"))
    assert not (out / "notes.txt").exists()  # the folder is built aside and replaces the old one whole
    assert unlinked_report_files(out, index.read_text()) == []
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # nothing left beside it


def unlinked_report_files(folder: Path, index_text: str) -> list[str]:
    """Files under a report folder's tables/ and figures/ that its index does not link."""
    linked = set(_links(index_text))
    return [
        f"{d}/{f.name}"
        for d in ("tables", "figures")
        for f in sorted((folder / d).glob("*"))
        if f"{d}/{f.name}" not in linked
    ]


def test_committed_report_links_every_file(repo_root: Path):
    """results/report (made by results/make_results.sh): its index links every table and figure."""
    folder = repo_root / "results" / "report"
    index = (folder / "index.md").read_text()
    assert unlinked_report_files(folder, index) == []
    for link in _links(index):
        assert (folder / link).is_file(), link
