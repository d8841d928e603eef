"""The runner: per-sample table, failures recorded, resume without repeated work."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

from catpose.bench.run.rundir import read_rows, run_dir_for
from catpose.bench.run.runner import run

TESTS = Path(__file__).resolve().parent


@pytest.fixture(autouse=True)
def _toy_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))


def make_cfg(tmp_path: Path, special=(), method_kwargs=None, overrides=()):
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose(
            config_name="run",
            overrides=[f"output_root={tmp_path / 'out'}", "progress=false", "print_summary=false", *overrides],
        )
    OmegaConf.set_struct(cfg, False)
    cfg.dataset = OmegaConf.create(
        {"name": "toy", "_target_": "toy_dataset.ToyDataset", "seed": 0, "num_views": 4, "special": list(special)}
    )
    cfg.method = OmegaConf.create(
        {
            "name": "oracle",
            "_target_": "toy_dataset.Oracle",
            "count_file": str(tmp_path / "calls.txt"),
            **(method_kwargs or {}),
        }
    )
    return cfg


def calls(tmp_path: Path) -> list[str]:
    p = tmp_path / "calls.txt"
    return p.read_text().split() if p.exists() else []


def test_run_writes_the_long_table_and_records_failures(tmp_path):
    cfg = make_cfg(
        tmp_path,
        special=["load_error", "empty", "nan", "collinear"],
        method_kwargs={"fail_on": ["v1"], "nan_on": ["v2"]},
    )
    out = run(cfg)
    rows = {r["sample_id"]: r for r in read_rows(out / "samples.jsonl")}
    assert len(rows) == 8
    assert rows["block/0/v0"]["status"] == "ok" and len(rows["block/0/v0"]["T_est"]) == 16
    assert rows["block/0/v0"]["rot_err_deg"] >= 0 and rows["block/0/v0"]["runtime_s"] >= 0
    assert rows["block/0/v1"]["status"] == "failed" and "blew up on purpose" in rows["block/0/v1"]["error"]
    assert rows["block/0/v2"]["status"] == "failed" and "non-finite" in rows["block/0/v2"]["error"]
    assert "malformed on purpose" in rows["block/0/load_error"]["error"]
    assert rows["block/0/load_error"]["stage"] == "load"
    assert "no points" in rows["block/0/empty"]["error"]
    assert "NaN" in rows["block/0/nan"]["error"]
    assert "degenerate" in rows["block/0/collinear"]["error"]
    for r in rows.values():
        assert "\n" not in r["error"] and "Traceback" not in r["error"]
    summary = pd.read_csv(out / "summary.csv").set_index("category")
    assert summary.loc["block", "n"] == 8 and summary.loc["block", "failed"] == 6
    # the two successes (identity estimates) have known errors; the failures count as 180 degrees
    ok_err = rows["block/0/v0"]["err_deg"] + rows["block/0/v3"]["err_deg"]
    assert summary.loc["block", "mean_err_deg"] == pytest.approx((ok_err + 6 * 180.0) / 8)
    assert (out / "config.yaml").exists() and (out / "git_rev.txt").read_text().strip()
    assert (out / "summary.md").read_text().startswith("| category")
    flat = pd.read_csv(out / "samples.csv")
    assert {"sample_id", "category", "method", "status", "error", "err_deg", "runtime_s", "T_est", "T_gt"} <= set(flat)


def test_resume_after_interrupt_gives_the_same_table_without_repeated_work(tmp_path, monkeypatch):
    full = run(make_cfg(tmp_path / "a"))
    reference = pd.read_csv(full / "summary.csv").drop(columns="median_runtime_s")
    assert len(calls(tmp_path / "a")) == 4

    b = tmp_path / "b"
    monkeypatch.setenv("TOY_INTERRUPT_ON", "v2")
    with pytest.raises(KeyboardInterrupt):
        run(make_cfg(b))
    monkeypatch.delenv("TOY_INTERRUPT_ON")
    out = next((b / "out").glob("*/*/*"))
    assert [r["sample_id"] for r in read_rows(out / "samples.jsonl")] == ["block/0/v0", "block/0/v1"]
    with open(out / "samples.jsonl", "a") as f:  # a kill in the middle of writing a line
        f.write('{"sample_id": "block/0/v2", "sta')
    out2 = run(make_cfg(b))
    assert out2 == out
    assert calls(b) == ["block/0/v0", "block/0/v1", "block/0/v2", "block/0/v2", "block/0/v3"]
    resumed = pd.read_csv(out / "summary.csv").drop(columns="median_runtime_s")
    pd.testing.assert_frame_equal(resumed, reference)
    assert len(read_rows(out / "samples.jsonl")) == 4

    run(make_cfg(b))  # a third run has nothing left to do
    assert len(calls(b)) == 5


def test_batched_runs_give_the_same_table_and_isolate_a_bad_sample(tmp_path):
    """batch=N feeds register_batch N samples at a time; a sample that fails to load stays out
    of the call, one that fails inside it makes its batch register one by one, and the table is
    the one batch=1 writes."""
    special = ["load_error"]
    plain = make_cfg(tmp_path / "a", special=special, method_kwargs={"fail_on": ["v1"]})
    rows_1 = {r["sample_id"]: r for r in read_rows(run(plain) / "samples.jsonl")}
    cfg = make_cfg(tmp_path / "b", special=special, method_kwargs={"fail_on": ["v1"]}, overrides=["batch=3"])
    cfg.method._target_ = "toy_dataset.BatchOracle"
    out = run(cfg)
    rows_3 = {r["sample_id"]: r for r in read_rows(out / "samples.jsonl")}
    assert run_dir_for(cfg, ["batch=3"]) == run_dir_for(cfg, []) == out  # batch is not part of the name
    assert rows_3.keys() == rows_1.keys()
    for sid, r in rows_1.items():
        assert (r["status"], r["error"], r.get("T_est")) == (
            rows_3[sid]["status"],
            rows_3[sid]["error"],
            rows_3[sid].get("T_est"),
        ), sid
    log = calls(tmp_path / "b")
    # samples v0 v1 v2 | v3 load_error: the first batch fails (v1) and registers one by one; the
    # second has one loadable sample and registers alone
    assert log[0] == "batch:3" and "batch:2" not in log
    assert sorted(x for x in log if not x.startswith("batch")) == sorted(
        s for s, r in rows_1.items() if r["stage"] != "load"
    )
    with pytest.raises(Exception, match="batch=0 is not an integer >= 1"):
        run(make_cfg(tmp_path / "c", overrides=["batch=0"]))


def test_output_directory_is_named_from_parameters(tmp_path):
    a = run(make_cfg(tmp_path, overrides=["seed=1"]))
    b = run(make_cfg(tmp_path, overrides=["seed=2"]))
    assert a != b and a.name.startswith("seed1") and b.name.startswith("seed2")
    assert a.parent.name == "oracle" and a.parent.parent.name == "toy-gt_model"


def test_same_seed_same_table(tmp_path):
    a = run(make_cfg(tmp_path / "a"))
    b = run(make_cfg(tmp_path / "b"))
    ra, rb = read_rows(a / "samples.jsonl"), read_rows(b / "samples.jsonl")
    assert [r["T_gt"] for r in ra] == [r["T_gt"] for r in rb]
    assert [r["err_deg"] for r in ra] == [r["err_deg"] for r in rb]


def test_templates_protocol_selects_by_score_and_reports_oracle(tmp_path):
    from catpose.bench.protocols.absolute import Templates

    df = pd.DataFrame(
        {
            "group_id": ["o1", "o1", "o2", "o2"],
            "category": ["c"] * 4,
            "status": ["ok", "ok", "ok", "failed"],
            "score": [2.0, 1.0, 5.0, None],
            "err_deg": [3.0, 50.0, 7.0, 180.0],
            "trans_err": [0.1, 0.2, 0.3, None],
            "runtime_s": [1.0, 1.0, 2.0, 2.0],
        }
    )
    units = Templates(choice="score").score_units(df).set_index("group_id")
    assert units.loc["o1", "err_deg"] == 50.0 and units.loc["o1", "oracle_err_deg"] == 3.0
    assert units.loc["o2", "err_deg"] == 7.0 and units.loc["o2", "runtime_s"] == 4.0
    # the oracle's translation error is its own registration's, not the kept one's
    assert units.loc["o1", "trans_err"] == 0.2 and units.loc["o1", "oracle_trans_err"] == 0.1
    assert units.loc["o2", "oracle_trans_err"] == 0.3
    from types import SimpleNamespace

    from catpose.bench.report.runs import scored_units

    oracle = scored_units(SimpleNamespace(config={}, protocol="templates", samples=df, path="r"), "oracle_err_deg")
    assert oracle.set_index("group_id")[["err_deg", "trans_err"]].loc["o1"].tolist() == [3.0, 0.1]


def test_views_without_absolute_ground_truth_are_not_scored():
    from catpose.bench.protocols.absolute import GtModel, Templates

    df = pd.DataFrame(
        {
            "group_id": ["a", "b"],
            "category": ["c", "c"],
            "status": ["ok", "ok"],
            "score": [1.0, 1.0],
            "err_deg": [3.0, 100.0],
            "trans_err": [0.1, 0.1],
            "runtime_s": [1.0, 1.0],
            "info": [{}, {"absolute_gt": False}],
        }
    )
    assert GtModel().score_units(df)["err_deg"].tolist() == [3.0]
    assert Templates().score_units(df)["err_deg"].tolist() == [3.0]


def test_a_limited_run_is_its_own_run_and_the_full_run_keeps_every_sample(tmp_path):
    """A subset is another sample set (issue 59): its own directory, never the full run's."""
    from catpose.bench.run.evaluate import summarize_run

    out = run(make_cfg(tmp_path))
    sub = summarize_run(out, ["block/0/v0", "block/0/v1"]).set_index("category")
    assert sub.loc["block", "n"] == 2
    assert pd.read_csv(out / "summary.csv").set_index("category").loc["block", "n"] == 4
    limited = run(make_cfg(tmp_path, overrides=["limit=2"]))
    assert limited != out and limited.parent == out.parent
    assert pd.read_csv(limited / "summary.csv").set_index("category").loc["block", "n"] == 2
    assert pd.read_csv(out / "summary.csv").set_index("category").loc["block", "n"] == 4


# ---------------------------------------------------------------------------------------------
# only a sample's own fault is a sample failure (issue 9, item 5)


def test_import_and_memory_errors_abort_the_run_and_record_nothing(tmp_path, monkeypatch):
    import toy_dataset

    from catpose.errors import RunAborted

    cfg = make_cfg(tmp_path)
    out = run(cfg)
    (out / "samples.jsonl").unlink()
    real = toy_dataset.Oracle.register
    for exc, needle in [
        (ModuleNotFoundError("No module named 'nosuch'", name="nosuch"), "cannot import nosuch"),
        (MemoryError(), "out of memory on sample block/0/v1"),
    ]:

        def register(self, problem, exc=exc):
            if problem.sample_id.endswith("v1"):
                raise exc
            return real(self, problem)

        monkeypatch.setattr(toy_dataset.Oracle, "register", register)
        with pytest.raises(RunAborted, match=needle) as info:
            run(make_cfg(tmp_path))
        assert "\n" not in str(info.value) and "re-run" in str(info.value)
        rows = read_rows(out / "samples.jsonl")
        assert [r["sample_id"] for r in rows] == ["block/0/v0"] and rows[0]["status"] == "ok"
    monkeypatch.setattr(toy_dataset.Oracle, "register", real)
    run(make_cfg(tmp_path))  # the re-run redoes the aborted sample
    rows = read_rows(out / "samples.jsonl")
    assert sorted(r["sample_id"] for r in rows) == [f"block/0/v{i}" for i in range(4)]
    assert all(r["status"] == "ok" for r in rows)


def test_a_ctrl_c_swallowed_inside_a_sample_still_stops_the_run(tmp_path, monkeypatch):
    """A library that catches KeyboardInterrupt (trimesh does, around imports) must not turn a
    Ctrl-C into a recorded failure: the runner's SIGINT handler remembers it."""
    import signal

    import toy_dataset

    real = toy_dataset.Oracle.register

    def register(self, problem):
        if problem.sample_id.endswith("v1"):
            try:
                signal.raise_signal(signal.SIGINT)
            except BaseException as e:  # noqa: BLE001 - what a careless library does
                raise RuntimeError("swallowed") from e
        return real(self, problem)

    monkeypatch.setattr(toy_dataset.Oracle, "register", register)
    # Python's own handler, as in a terminal: a shell that starts the tests in the background
    # (`make test &`) hands them SIGINT ignored, and the runner leaves that choice alone
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            run(make_cfg(tmp_path))
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
    finally:
        signal.signal(signal.SIGINT, previous)
    out = next((tmp_path / "out").glob("*/*/*"))
    assert [r["sample_id"] for r in read_rows(out / "samples.jsonl")] == ["block/0/v0"]


def test_heavy_libraries_are_imported_before_the_first_sample(tmp_path):
    import sys

    import toy_dataset

    seen = {}
    real = toy_dataset.Oracle.register

    def register(self, problem):
        seen.update({m: m in sys.modules for m in ("torch", "open3d", "trimesh", "scipy.spatial")})
        return real(self, problem)

    toy_dataset.Oracle.register = register
    try:
        run(make_cfg(tmp_path))
    finally:
        toy_dataset.Oracle.register = real
    assert seen and all(seen.values()), seen


_SWALLOWED_IN_TRIMESH = """
import signal, sys
from catpose.bench.run import runner

class CtrlCWhileTrimeshImportsPath:  # trimesh.base wraps `from .path import Path3D` in `except BaseException`
    def find_spec(self, name, path=None, target=None):
        if name == "trimesh.path":
            print("Ctrl-C;", end=" ")
            signal.raise_signal(signal.SIGINT)
        return None

sys.meta_path.insert(0, CtrlCWhileTrimeshImportsPath())
try:
    with runner._Interrupts() as interrupts:
        runner.import_heavy_libraries(interrupts)
except KeyboardInterrupt:
    print("stopped")
    sys.exit(0)
print("not stopped")
sys.exit(1)
"""


def test_ctrl_c_swallowed_by_trimesh_during_its_import_still_stops_the_run():
    r = subprocess.run(
        [sys.executable, "-c", _SWALLOWED_IN_TRIMESH],
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # trimesh did swallow it (its Path3D became an ExceptionWrapper, and then its import failed with a
    # TypeError), and the run stopped with KeyboardInterrupt anyway
    assert r.returncode == 0 and r.stdout.startswith("Ctrl-C;") and r.stdout.strip().endswith("stopped"), (
        r.stdout,
        r.stderr[-2000:],
    )


BENCH = [sys.executable, "-m", "catpose.bench.cli"]
TINY_RUN = [
    "run",
    "method=icp",
    "dataset=synthetic",
    "dataset.categories=[car,bottle]",
    "dataset.instances_per_category=1",
    "dataset.views_per_instance=2",
    "limit=3",
    "progress=false",
]


def _start_bench(tmp_path: Path, env_extra: dict[str, str] | None = None) -> subprocess.Popen:
    # SIGINT at its default even where the test runner was started with it ignored (nohup, CI)
    import os

    return subprocess.Popen(
        [*BENCH, *TINY_RUN, f"output_root={tmp_path}"],
        cwd=tmp_path,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=dict(os.environ, **(env_extra or {})),
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _interrupt(p: subprocess.Popen) -> tuple[str, float]:
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    return err, time.monotonic() - t0


def _rows(tmp_path: Path) -> list[dict]:
    return [r for f in tmp_path.glob("*/*/*/samples.jsonl") for r in read_rows(f)]


def _check_clean_abort(p: subprocess.Popen, err: str, tmp_path: Path) -> None:
    assert p.returncode in (130, -2), (p.returncode, err)  # -2: Python re-raised SIGINT at exit (shell: 130)
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and "interrupted" in err, err
    for r in _rows(tmp_path):
        assert r["status"] == "ok", r  # no ImportError / KeyboardInterrupt recorded as a failure


#: A ``sitecustomize`` that holds the run inside the import of one module until Ctrl-C arrives:
#: it prints a marker when the import starts, so the test interrupts at that point and no other,
#: whatever the machine's speed (the KeyboardInterrupt surfaces from that import, as a real Ctrl-C
#: there would).
_HOLD_IMPORT = """
import sys, threading

class _HoldImport:
    def __init__(self, target):
        self.target, self.fired = target, False

    def find_spec(self, name, path=None, target=None):
        if name == self.target and not self.fired:
            self.fired = True
            sys.stderr.write("catpose-test: importing " + name + "\\n")
            sys.stderr.flush()
            threading.Event().wait()  # hold the import until the test's signal ends the process
        return None

sys.meta_path.insert(0, _HoldImport(TARGET))
"""


@pytest.mark.parametrize("module", ["hydra", "trimesh", "torch", "open3d"])
def test_ctrl_c_during_start_up_stops_the_run_cleanly(tmp_path, module):
    """Ctrl-C while Hydra, trimesh, torch or Open3D is being imported (a Ctrl-C during torch's or
    Open3D's import used to record an ImportError for every sample). The signal is sent once the
    run says it is inside that import, not after a delay."""
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(f"TARGET = {module!r}\n" + _HOLD_IMPORT)
    p = _start_bench(tmp_path, {"PYTHONPATH": str(hook)})
    for line in p.stderr:
        if line.startswith("catpose-test: importing"):
            break
    else:
        p.wait(timeout=60)
        pytest.fail(f"the run never imported {module} (exit {p.returncode})")
    err, _ = _interrupt(p)
    _check_clean_abort(p, err, tmp_path)


@pytest.mark.slow
def test_ctrl_c_mid_loop_then_rerun_completes(tmp_path):
    p = _start_bench(tmp_path)
    deadline = time.monotonic() + 120
    while not _rows(tmp_path) and time.monotonic() < deadline and p.poll() is None:
        try:  # wait for the process a moment, then look for its first row again
            p.wait(timeout=0.05)
        except subprocess.TimeoutExpired:
            pass
    err, _ = _interrupt(p)
    _check_clean_abort(p, err, tmp_path)
    n_before = len(_rows(tmp_path))
    assert 1 <= n_before < 3
    r = subprocess.run(
        [*BENCH, *TINY_RUN, f"output_root={tmp_path}"], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr[-2000:]
    run_dir = next(tmp_path.glob("*/*/*"))
    assert json.loads((run_dir / "run.json").read_text())["n_run_now"] == 3 - n_before
    assert sorted(r["status"] for r in _rows(tmp_path)) == ["ok"] * 3


def test_run_json_records_the_environment(tmp_path):
    """run.json holds the versions, CPU and BLAS kernel the numbers came from, and the threads."""
    import json

    from hydra import compose, initialize_config_module

    from catpose import kernel_threads
    from catpose.bench.run.runner import run

    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose(
            "run",
            overrides=[
                "method=icp",
                "method.num_starts=1",
                "dataset.categories=[bowl]",
                "dataset.instances_per_category=1",
                "dataset.views_per_instance=1",
                f"output_root={tmp_path}",
                "progress=false",
                "print_summary=false",
                "threads=auto",
            ],
        )
    meta = json.loads((run(cfg) / "run.json").read_text())
    env = meta["environment"]
    assert meta["threads"] == kernel_threads.available()  # what auto came to, the runtimes' context
    assert {"numpy", "scipy", "torch", "trimesh"} <= set(env["versions"])
    assert env["cpu"] and isinstance(env["blas"], list)
