"""The per-sample regression gate: golden inputs, comparison rules, chaos flags, and proof that
it fails on a real injected regression and passes on the committed reference."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from catpose.bench.regress import reference, regress_gate, run_suites
from catpose.bench.regress.golden import perturbed, read_golden, write_golden


def _row(err, status="ok", T=None, category="mug"):
    T = np.eye(4).reshape(-1).tolist() if T is None else T
    return {
        "category": category,
        "status": status,
        "error": "" if status == "ok" else "boom",
        "err_deg": err,
        "trans_err": 0.01,
        "T_est": T if status == "ok" else None,
        "T_gt": np.eye(4).reshape(-1).tolist(),
        "symmetry_axis": None,
        "symmetries": [],
    }


def _rot_z(deg):
    from catpose.geometry import axis_angle_to_R, make_T

    return make_T(axis_angle_to_R(np.array([0.0, 0.0, 1.0]), np.deg2rad(deg)), np.zeros(3)).reshape(-1).tolist()


def _reference(rows, chaotic=(), gate=run_suites.Gate()):
    samples = {k: dict(v, chaotic=k in chaotic) for k, v in rows.items()}
    return {"samples": samples, "aggregates": regress_gate.aggregates(samples, set(samples) - set(chaotic), gate)}


def test_compare_flags_a_stable_sample_leaving_10_degrees_but_not_a_chaotic_one():
    gate = run_suites.Gate()
    ref = _reference(
        {"a": _row(2.0, T=_rot_z(2)), "b": _row(3.0, T=_rot_z(3)), "c": _row(1.0, T=_rot_z(1))}, chaotic={"c"}
    )
    cur = {"a": _row(40.0, T=_rot_z(40)), "b": _row(3.2, T=_rot_z(3.2)), "c": _row(150.0, T=_rot_z(150))}
    found = run_suites.compare_method("icp", ref, cur, gate)
    by_where = {f.where: f for f in found}
    assert by_where["a"].fails and "left 10 deg" in by_where["a"].what and "moved 38.00" in by_where["a"].what
    assert "b" not in by_where  # moved 0.2 deg: within the chaos threshold, not reported
    assert not by_where["c"].fails and by_where["c"].what.startswith("chaotic")
    # the aggregates are over stable samples only: a's jump moves mug's mean by 19 deg
    assert by_where["mug/mean_err_deg"].fails and by_where["all/acc10"].fails
    assert "mug/n" not in by_where


def test_compare_fails_on_new_failures_and_missing_samples():
    gate = run_suites.Gate()
    ref = _reference({"a": _row(2.0), "b": _row(5.0)})
    found = run_suites.compare_method("fgr", ref, {"a": _row(0.0, status="failed")}, gate)
    texts = {f.where: f.what for f in found if f.fails}
    assert texts["a"].startswith("failed now (boom)") and "not run now" in texts["b"]


def test_accuracy_tolerance_counts_samples_near_the_threshold():
    gate = run_suites.Gate()
    agg = regress_gate.aggregates(
        {"a": _row(9.5), "b": _row(2.0), "c": _row(50.0), "d": _row(30.4)}, {"a", "b", "c", "d"}, gate
    )
    assert agg["all"]["acc10"] == 0.5 and agg["all"]["acc10_tolerance"] == 0.25
    # errors are clipped at wrong_deg = 30: (9.5 + 2 + 30 + 30) / 4
    assert agg["all"]["acc30_tolerance"] == 0.25 and agg["all"]["mean_err_deg"] == pytest.approx(17.875)


def test_a_wrong_answer_that_moves_is_not_a_regression():
    """The TEASER bowl case: a stable sample at 139 deg that moves to 145 deg under another CPU
    is reported, never failed on, and moves no aggregate (errors clipped at 30, translation
    averaged over the reference's right samples)."""
    gate = run_suites.Gate()
    ref = _reference({"a": _row(139.0, T=_rot_z(139)), "b": _row(2.0, T=_rot_z(2))})
    moved = dict(_row(145.0, T=_rot_z(145)), trans_err=3.0)
    found = run_suites.compare_method("teaser", ref, {"a": moved, "b": _row(2.0, T=_rot_z(2))}, gate)
    assert [f.where for f in found] == ["a"] and not found[0].fails and "not gated" in found[0].what
    back = run_suites.compare_method("teaser", ref, {"a": _row(5.0, T=_rot_z(5)), "b": _row(2.0, T=_rot_z(2))}, gate)
    assert not any(f.fails for f in back if f.where == "a") and "now within 30 deg" in back[0].what


def test_a_stable_sample_leaving_30_degrees_fails():
    gate = run_suites.Gate()
    ref = _reference({"a": _row(20.0, T=_rot_z(20)), "b": _row(2.0, T=_rot_z(2))})
    found = {
        f.where: f
        for f in run_suites.compare_method(
            "icp", ref, {"a": _row(60.0, T=_rot_z(60)), "b": _row(2.0, T=_rot_z(2))}, gate
        )
    }
    assert found["a"].fails and "left 30 deg" in found["a"].what


def test_chaos_detection_covers_every_code_path_of_this_cpu(monkeypatch):
    """--update re-runs under each OpenBLAS kernel the CPU offers other than its own, NumPy without
    AVX-512 where it has it, and torch's default kernels."""
    from catpose.bench.run import environment

    monkeypatch.setattr(environment, "cpu_flags", lambda: ["avx", "avx2", "avx512f", "fma"])
    monkeypatch.setattr(environment, "numpy_blas_kernel", lambda: "SkylakeX")
    monkeypatch.delenv("OPENBLAS_CORETYPE", raising=False)
    paths = reference.other_code_paths()
    assert set(paths) == {"Haswell", "Sandybridge", "avx2-profile", "torch-default"}
    assert paths["avx2-profile"]["OPENBLAS_CORETYPE"] == "Haswell"
    monkeypatch.setattr(environment, "cpu_flags", lambda: ["avx", "avx2", "fma"])
    monkeypatch.setattr(environment, "numpy_blas_kernel", lambda: "Haswell")
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Haswell")
    assert set(reference.other_code_paths()) == {"Sandybridge", "torch-default"}


def test_golden_round_trip_is_bit_exact_and_perturbation_is_tiny(tmp_path: Path):
    from catpose.bench.protocols.absolute import GtModel
    from catpose.datasets.synthetic import SyntheticDataset
    from catpose.datasets.views import ViewOptions

    ds = SyntheticDataset(
        seed=0,
        categories=["mug", "can"],
        instances_per_category=1,
        views_per_instance=1,
        view=ViewOptions(max_points=300),
        template_points=300,
    )
    proto = GtModel()
    samples = [proto.load(ds, sid) for sid in proto.sample_ids(ds)]
    path = write_golden(tmp_path / "g.npz", "t", ["x=1"], samples)
    a, b = read_golden(path), read_golden(path)
    assert [s.problem.sample_id for s in a] == [s.problem.sample_id for s in samples]
    for s, r, r2 in zip(samples, a, b):
        assert np.array_equal(r.problem.points_camera, r2.problem.points_camera)
        assert np.allclose(r.problem.points_camera, s.problem.points_camera, atol=1e-6)
        assert np.array_equal(r.gt.T_template_camera, s.gt.T_template_camera)
        assert (r.gt.symmetry_axis is None) == (s.gt.symmetry_axis is None)
        p = perturbed(r, 1e-12, 7).problem.points_camera
        rel = np.abs(p - r.problem.points_camera) / np.maximum(np.abs(r.problem.points_camera), 1e-300)
        assert 0 < rel.max() < 1e-10


def test_default_config_and_committed_reference_agree(repo_root: Path):
    gate, suites = run_suites.load_config(repo_root / "configs" / "regress" / "default.yaml")
    suite = suites["synthetic"]
    golden = read_golden(suite.inputs)
    assert len(golden) == 24 and len({s.problem.category for s in golden}) == 8
    doc = json.loads(suite.reference.read_text())
    assert doc["format"] == 2 and doc["environment"]["versions"]["numpy"]
    for method, entry in doc["methods"].items():
        assert set(entry["samples"]) == {s.problem.sample_id for s in golden}, method
        assert all("chaotic" in r and r["code_path_moves_deg"] for r in entry["samples"].values())
        assert "all" in entry["aggregates"]


def test_config_errors_name_the_key(tmp_path: Path):
    bad = tmp_path / "r.yaml"
    bad.write_text(yaml.safe_dump({"gate": {"chaos": 1}, "suites": {"s": {"dataset": "synthetic"}}}))
    with pytest.raises(Exception, match="unknown gate keys"):
        run_suites.load_config(bad)
    assert run_suites.main(["--config", str(tmp_path / "nope.yaml")]) == 2


def _injected_config(tmp_path: Path, repo_root: Path, overrides: list[str]) -> Path:
    cfg = yaml.safe_load((repo_root / "configs" / "regress" / "default.yaml").read_text())
    suite = cfg["suites"]["synthetic"]
    suite["inputs"] = str(repo_root / suite["inputs"])
    suite["reference"] = str(repo_root / suite["reference"])
    suite["method_overrides"] = {"icp": overrides}
    cfg["suites"] = {"synthetic": suite}
    path = tmp_path / "regress.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def test_injected_regression_fails_the_gate(tmp_path: Path, repo_root: Path, capsys):
    """ICP started from 1 rotation instead of 20 is a real regression; the gate must exit 1 and
    name the samples that left 10 degrees."""
    path = _injected_config(tmp_path, repo_root, ["method.num_starts=1"])
    assert run_suites.main(["--config", str(path), "--methods", "icp", "--jobs", "1"]) == 1
    err = capsys.readouterr().err
    assert "REGRESSION" in err and "left 10 deg" in err and "icp all/mean_err_deg" in err


@pytest.mark.slow
def test_committed_reference_passes_under_every_blas_kernel(repo_root: Path):
    """The committed reference holds under every OpenBLAS kernel this CPU runs (what .ci/run also
    checks)."""
    from catpose.bench.run.environment import numeric_variants

    kernels = [v["OPENBLAS_CORETYPE"] for v in numeric_variants().values() if set(v) == {"OPENBLAS_CORETYPE"}]
    for kernel in kernels or ["Haswell"]:
        proc = subprocess.run(
            [sys.executable, "-m", "catpose.bench.regress.run_suites", "--suite", "synthetic", "--methods", "icp,ours"],
            env=dict(os.environ, OPENBLAS_CORETYPE=kernel),
            capture_output=True,
            text=True,
            cwd=repo_root,
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr


def test_methods_of_one_suite_leave_the_other_suites_out(tmp_path: Path, repo_root: Path, monkeypatch, capsys):
    """``--methods teaser`` with a suite that has no TEASER: that suite is skipped with a note (it
    was run with no methods, and ``--update``'s chaos detection then failed on it)."""
    cfg = yaml.safe_load((repo_root / "configs" / "regress" / "default.yaml").read_text())
    suite = cfg["suites"]["synthetic"]
    suite["inputs"] = str(repo_root / suite["inputs"])
    suite["reference"] = str(repo_root / suite["reference"])
    cfg["suites"] = {"synthetic": suite, "icp_only": dict(suite, methods=["icp"])}
    path = tmp_path / "regress.yaml"
    path.write_text(yaml.safe_dump(cfg))
    calls = []
    monkeypatch.setattr(
        run_suites, "check_suite", lambda s, methods, gate, jobs: (calls.append(list(methods)), ([], []))[1]
    )
    assert run_suites.main(["--config", str(path), "--methods", "teaser"]) == 0
    assert calls == [["teaser"]]
    assert "icp_only: skipped (none of --methods teaser is among its methods)" in capsys.readouterr().out


def test_a_gate_worker_takes_one_thread_under_threads_auto(monkeypatch):
    """The gate's worker processes are its parallelism: their ``threads=auto`` resolves to 1."""
    from catpose import kernel_threads

    monkeypatch.setenv("OMP_NUM_THREADS", "4")  # recorded: the test leaves the environment as it was
    run_suites._one_thread()
    assert os.environ["OMP_NUM_THREADS"] == "1"
    assert kernel_threads.resolve(kernel_threads.AUTO) == 1
