"""``bench perf``: interleaving, statistics, CSV output and its command line (no timing asserts)."""

from __future__ import annotations

import csv
import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from catpose.bench.perf import registration as perf
from catpose.errors import ConfigError
from catpose.types import RegistrationResult


class _Recorder:
    """A method that records the order of its calls (shared log) and reports a stage timing."""

    def __init__(self, name: str, log: list) -> None:
        self.name, self.log = name, log

    def register(self, problem):
        self.log.append((self.name, problem.sample_id))
        return RegistrationResult(T_template_camera=np.eye(4), score=0.0, extras={"timings": {"optimization": 0.001}})


def _problems(k: int, templates: int = 2):
    return [
        SimpleNamespace(sample_id=f"s{i}", template=SimpleNamespace(template_id=f"t{i % templates}")) for i in range(k)
    ]


def test_methods_are_interleaved_per_call_and_rotate_per_round():
    log: list = []
    methods = {"a": _Recorder("a", log), "b": _Recorder("b", log)}
    out = perf.measure(methods, _problems(3), repeat=2, seed=0)
    # s0: warm-up of its new template t0 (untimed), then round 1 (a, b) and round 2 (b, a)
    assert log[:6] == [("a", "s0"), ("b", "s0"), ("a", "s0"), ("b", "s0"), ("b", "s0"), ("a", "s0")]
    assert log[6:12] == [("a", "s1"), ("b", "s1"), ("a", "s1"), ("b", "s1"), ("b", "s1"), ("a", "s1")]
    assert log[12:] == [("a", "s2"), ("b", "s2"), ("b", "s2"), ("a", "s2")]  # t0 again: no warm-up
    assert [len(out[m]["times"]) for m in "ab"] == [6, 6]
    assert out["a"]["stages"]["optimization"] == [0.001] * 6
    assert out["a"]["warmup_s"] > 0


def test_summary_statistics_and_ratio_to_fgr():
    measured = {
        "fgr": {"times": [1.0, 2.0, 3.0], "warmup_s": 0.0},
        "ours": {"times": [2.0, 4.0, 6.0, 100.0], "warmup_s": 0.0},
    }
    rows = {r["method"]: r for r in perf.summarize(measured)}
    assert rows["fgr"]["ratio_to_fgr"] == 1.0
    assert rows["ours"]["median_s"] == 5.0 and rows["ours"]["ratio_to_fgr"] == 2.5
    assert rows["ours"]["mean_s"] == pytest.approx(28.0)
    assert rows["ours"]["p90_s"] == pytest.approx(np.percentile([2, 4, 6, 100], 90))
    only = perf.summarize({"ours": measured["ours"]})
    assert np.isnan(only[0]["ratio_to_fgr"])


def test_problems_are_taken_round_robin_over_categories():
    problems, label = perf.load_problems(
        "synthetic",
        "gt_model",
        4,
        0,
        overrides=[
            "dataset.instances_per_category=1",
            "dataset.views_per_instance=2",
            "dataset.categories=[chair,mug]",
        ],
    )
    assert [p.category for p in problems] == ["chair", "mug", "chair", "mug"]
    assert "synthetic" in label


def test_cli_writes_the_table_and_csvs(tmp_path, capsys):
    out = tmp_path / "perf.csv"
    rc = perf.main(
        [
            "--methods",
            "fgr",
            "--n",
            "2",
            "--repeat",
            "2",
            "--dataset-set",
            "categories=[chair]",
            "--dataset-set",
            "instances_per_category=1",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "| fgr" in text and "load average" in text
    rows = list(csv.DictReader(open(out)))
    assert rows[0]["method"] == "fgr" and float(rows[0]["ratio_to_fgr"]) == 1.0 and rows[0]["n"] == "4"
    assert float(rows[0]["peak_rss_mb"]) > 0
    times = list(csv.DictReader(open(tmp_path / "perf_times.csv")))
    assert len(times) == 4 and all(float(r["seconds"]) > 0 for r in times)
    source = inspect.getsource(perf)
    assert "_ours_fixtures" not in source and "sys.path" not in source  # bench never imports from tests/


def test_bad_arguments_are_config_errors():
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        perf.main(["--set", "nonsense"])
    with pytest.raises(ConfigError, match="at least 1"):
        perf.main(["--repeat", "0"])
    for bad in ("0", "two", "1.5"):
        with pytest.raises(ConfigError, match="--threads"):
            perf.main(["--threads", bad])


def test_labels_let_one_config_run_twice_with_its_own_options():
    assert perf.parse_methods("ours, adam=ours ,fgr") == [("ours", "ours"), ("adam", "ours"), ("fgr", "fgr")]
    with pytest.raises(ConfigError, match="repeats a label"):
        perf.parse_methods("ours,ours")
    sets = ["lr=0.1", "adam:optimiser.solver=adam", "ransac2:num_threads=2"]
    assert perf.method_overrides("ours", "ours", sets) == ["lr=0.1"]
    assert perf.method_overrides("adam", "ours", sets) == ["lr=0.1", "optimiser.solver=adam"]
    assert perf.method_overrides("ransac2", "ransac", sets) == ["num_threads=2"]
    assert perf.method_overrides("fgr", "fgr", sets) == []


class _NoPoseOn:
    """A method that gives no pose (InvalidInputError, as TEASER on a degenerate clique) on some samples."""

    def __init__(self, bad: set[str]) -> None:
        self.bad = bad

    def register(self, problem):
        from catpose.errors import InvalidInputError

        if problem.sample_id in self.bad:
            raise InvalidInputError(f"{problem.sample_id}: no pose")
        return RegistrationResult(T_template_camera=np.eye(4), score=0.0, extras={})


def test_a_registration_without_pose_is_timed_and_counted_not_fatal():
    out = perf.measure({"m": _NoPoseOn({"s1"}), "fgr": _Recorder("fgr", [])}, _problems(3), repeat=2, seed=0)
    assert len(out["m"]["times"]) == 6 and out["m"]["failed"] == 2 and out["fgr"]["failed"] == 0
    rows = {r["method"]: r for r in perf.summarize(out)}
    assert rows["m"]["failed"] == 2 and rows["m"]["n"] == 6


def test_every_stage_ours_times_is_one_bench_perf_reports():
    """The stage table accounts for ours' time: each key ours writes into its ``timings`` (read
    from the source of its modules) is one of ``STAGES``."""
    import re
    from pathlib import Path

    import catpose.methods.ours as ours

    keys = set()
    for path in Path(ours.__file__).parent.glob("*.py"):
        keys |= set(re.findall(r'timings(?:\.get\(|\[)"([a-z_]+)"', path.read_text()))
    assert {"rest_grid", "verification", "refinement"} <= keys
    assert keys <= set(perf.STAGES), sorted(keys - set(perf.STAGES))
