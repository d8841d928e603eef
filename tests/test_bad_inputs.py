"""Bad inputs a new user can give (issue 9, item 6): each gives one line naming the key or file
and the fix, never a traceback, a silent change of meaning, or a stall.

Most cases run in-process (fast); ``test_bench_run_gives_one_line`` checks them end to end
through ``bench run`` (exit code 2, one line on stderr) and is marked slow.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

from catpose.bench.run import rundir
from catpose.bench.run.build import build_from_config
from catpose.bench.run.rundir import LOCK_FILE, read_rows
from catpose.bench.run.runner import run
from catpose.errors import ConfigError, DatasetError, RunAborted

TESTS = Path(__file__).resolve().parent
BENCH = [sys.executable, "-m", "catpose.bench.cli"]


@pytest.fixture(autouse=True)
def _toy_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))


def toy_cfg(tmp_path: Path, overrides=(), output_root: Path | None = None):
    """The run config with the tiny toy dataset and oracle method of ``toy_dataset.py``."""
    root = output_root if output_root is not None else tmp_path / "out"
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose(
            config_name="run", overrides=[f"output_root={root}", "progress=false", "print_summary=false", *overrides]
        )
    OmegaConf.set_struct(cfg, False)
    cfg.dataset = OmegaConf.create({"name": "toy", "_target_": "toy_dataset.ToyDataset", "seed": 0, "num_views": 3})
    cfg.method = OmegaConf.create({"name": "oracle", "_target_": "toy_dataset.Oracle"})
    return cfg


def one_line(exc: BaseException) -> str:
    msg = str(exc)
    assert "\n" not in msg and "Traceback" not in msg, msg
    return msg


# ------------------------------------------------------------------ fixtures on disk


def write_bop(root: Path, cam_K=(300.0, 0, 159.5, 0, 300.0, 119.5, 0, 0, 1), gt_entry=None, models_info=None) -> Path:
    """A BOP tree just complete enough to be indexed (the depth PNG only has to exist)."""
    scene = root / "test" / "000001"
    (scene / "depth").mkdir(parents=True)
    (root / "models").mkdir(parents=True)
    (scene / "depth" / "000000.png").write_bytes(b"not read when indexing")
    entry = (
        gt_entry
        if gt_entry is not None
        else {"obj_id": 19, "cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 500]}
    )
    (scene / "scene_gt.json").write_text(json.dumps({"0": [entry]}))
    (scene / "scene_camera.json").write_text(json.dumps({"0": {"cam_K": list(cam_K), "depth_scale": 1.0}}))
    (root / "models" / "models_info.json").write_text(json.dumps(models_info if models_info is not None else {}))
    return root


def write_off(path: Path, vertex_lines: list[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("OFF\n3 1 0\n" + "\n".join(vertex_lines) + "\n3 0 1 2\n")
    return path


# ------------------------------------------------------------------ in-process cases


@pytest.mark.parametrize(
    "overrides, needle",
    [
        (["limit=-1"], "limit=-1 is not an integer >= 1; set limit=<integer >= 1>"),
        (["limit=0"], "limit=0 is not an integer >= 1"),
        (["limit=abc"], "limit='abc' is not an integer >= 1"),
        (["seed=1.5"], "seed=1.5 is not an integer; set seed=<integer>"),
        (["seed=abc"], "seed='abc' is not an integer"),
        (["threads=0"], "threads=0 is not auto or an integer >= 1; set threads=auto"),
        (["threads=two"], "threads='two' is not auto or an integer >= 1"),
        (["threads=2.0"], "threads=2.0 is not auto or an integer >= 1"),
        (["lock_timeout=-2"], "lock_timeout=-2 is not a number >= 0"),
    ],
)
def test_run_options_are_checked_before_any_work(tmp_path, overrides, needle):
    with pytest.raises(ConfigError) as info:
        run(toy_cfg(tmp_path, overrides))
    assert needle in one_line(info.value)
    assert not (tmp_path / "out").exists()  # nothing written


def test_a_limit_keeps_exactly_that_many_samples(tmp_path):
    out = run(toy_cfg(tmp_path, ["limit=3"]))  # all three (limit=-1 used to drop the last one)
    assert [r["sample_id"] for r in read_rows(out / "samples.jsonl")] == [f"block/0/v{i}" for i in range(3)]


_OPT = "catpose.methods.ours.settings.OptimiserSettings"
_SEL = "catpose.methods.ours.settings.SelectionSettings"


@pytest.mark.parametrize(
    "group, options, needle",
    [
        (
            "method",
            {"optimiser": {"_target_": _OPT, "lr": "abc"}},
            "method.optimiser.lr='abc' must be a positive number",
        ),
        (
            "method",
            {"optimiser": {"_target_": _OPT, "steps_pose": 1.5}},
            "method.optimiser.steps_pose=1.5 must be an integer >= 0",
        ),
        (
            "method",
            {"selection": {"_target_": _SEL, "refine": "maybe"}},
            "method.selection.refine='maybe' must be true or false",
        ),
        (
            "method",
            {"selection": {"_target_": _SEL, "gravity_max_deg": "x"}},
            "method.selection.gravity_max_deg='x' must be a number of degrees or null",
        ),
        ("method", {"no_such_option": 1}, "method.no_such_option is not an option of method 'ours'"),
        ("method", {"optimiser": {"_target_": _OPT, "lr_typo": 1}}, "method.optimiser.lr_typo is not an option"),
    ],
)
def test_wrong_option_values_name_the_key(group, options, needle):
    node = OmegaConf.create({"name": "ours", "_target_": "catpose.methods.ours.Ours", **options})
    with pytest.raises(ConfigError) as info:
        build_from_config(node, group)
    assert needle in one_line(info.value)


@pytest.mark.parametrize(
    "annotation, kinds",
    [
        ("float", {"float"}),
        ("int | None", {"int", "None"}),
        ("Optional[float]", {"float", "None"}),
        (float, {"float"}),
        ("list[float]", None),
        ("tuple[float, ...] | list[float]", None),
        ("None", None),
    ],
)
def test_scalar_annotations_are_read(annotation, kinds):
    from catpose.bench.run.build import _scalar_annotation

    assert _scalar_annotation(annotation) == kinds


def test_right_option_values_pass_the_check():
    from catpose.bench.run.build import check_constructor_args

    # an int for a float, an integral float for an int, None for an optional, a number for a str
    check_constructor_args(
        {
            "_target_": "catpose.methods.ours.Ours",
            "optimiser": {"_target_": _OPT, "lr": 1, "steps_pose": 300.0, "device": "cpu"},
            "selection": {"_target_": _SEL, "gravity_max_deg": None},
        },
        "method",
        "ours",
    )


def test_every_shipped_config_passes_the_type_check():
    from catpose.bench.run.build import check_constructor_args
    from catpose.bench.run.config import available

    for group in ("method", "dataset", "protocol"):
        for name in available(group):
            with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
                cfg = compose(config_name="run", overrides=[f"{group}={name}"])
            d = OmegaConf.to_container(cfg[group], resolve=False)
            d.pop("name", None)
            d = {k: v for k, v in d.items() if v != "???" and not (isinstance(v, str) and "${" in v)}
            check_constructor_args(d, group, name)


def test_missing_dataset_root_hint_is_a_working_override(tmp_path):
    cfg = toy_cfg(tmp_path)
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg.dataset = compose(config_name="run", overrides=["dataset=bop"]).dataset
    with pytest.raises(ConfigError) as info:
        run(cfg)
    msg = one_line(info.value)
    assert "dataset.root=<value>" in msg and "dataset.dataset" not in msg


@pytest.mark.parametrize(
    "cam_K, needle",
    [
        ((-300.0, 0, 159.5, 0, 300.0, 119.5, 0, 0, 1), "fx=-300, fy=300"),
        ((300.0, 0, 159.5, 0, 0.0, 119.5, 0, 0, 1), "fx=300, fy=0"),
        ((0.0, 0, 159.5, 0, 0.0, 119.5, 0, 0, 1), "fx=0, fy=0"),
    ],
)
def test_bop_non_positive_focal_length_fails_when_indexing(tmp_path, cam_K, needle):
    from catpose.datasets.bop import BOP
    from catpose.datasets.templates import TemplateOptions

    root = write_bop(tmp_path / "bop", cam_K=cam_K)
    with pytest.raises(DatasetError) as info:
        BOP(str(root), categories={19: "basket"}, template=TemplateOptions(templates={})).observation_ids()
    msg = one_line(info.value)
    assert needle in msg and "scene_camera.json" in msg and "fix cam_K" in msg


@pytest.mark.parametrize(
    "entry",
    [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 1]}, {"obj_id": "nineteen"}, "not an object"],
)
def test_bop_scene_gt_entry_without_obj_id_names_the_file(tmp_path, entry):
    from catpose.datasets.bop import BOP
    from catpose.datasets.templates import TemplateOptions

    root = write_bop(tmp_path / "bop", gt_entry=entry)
    with pytest.raises(DatasetError) as info:
        BOP(str(root), categories={19: "basket"}, template=TemplateOptions(templates={})).observation_ids()
    msg = one_line(info.value)
    assert "scene_gt.json" in msg and "entry 0 of image 0 has no integer obj_id" in msg


def test_bop_object_missing_from_models_info_warns_once(tmp_path):
    from catpose.datasets.bop import BOP
    from catpose.datasets.templates import TemplateOptions

    root = write_bop(tmp_path / "bop", models_info={"7": {"diameter": 10.0}})
    ds = BOP(str(root), categories={19: "basket"}, template=TemplateOptions(templates={}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert ds.symmetry_axis(19, "basket") is None
        assert ds.symmetry_axis(19, "basket") is None  # asked again (every view): no second warning
    msgs = [str(w.message) for w in caught]
    assert len(msgs) == 1 and "models_info.json has no entry for object 19" in msgs[0], msgs
    assert "dataset.symmetric" in msgs[0]


def test_bench_shows_catpose_warnings_in_one_line(monkeypatch):
    import catpose.datasets.bop as bop
    from catpose.bench.cli import _one_line_catpose_warnings

    monkeypatch.setattr(warnings, "formatwarning", warnings.formatwarning)  # restored afterwards
    _one_line_catpose_warnings()
    assert (
        warnings.formatwarning("no entry for object 19", UserWarning, bop.__file__, 1)
        == "bench: warning: no entry for object 19\n"
    )
    assert warnings.formatwarning("other", UserWarning, warnings.__file__, 1).count("UserWarning") == 1


@pytest.mark.parametrize("key, value", [("fx", 0.0), ("fx", -525.0), ("fy", 0.0), ("fx", float("nan"))])
def test_redwood_non_positive_focal_length(tmp_path, key, value):
    from catpose.datasets.redwood import Redwood

    with pytest.raises(ConfigError) as info:
        Redwood(str(tmp_path), **{key: value})
    msg = one_line(info.value)
    assert f"dataset.{key}=" in msg and f"set dataset.{key}=<pixels>" in msg


@pytest.mark.parametrize(
    "key, value", [("views_per_instance", 0), ("views_per_instance", -1), ("instances_per_category", 0)]
)
def test_modelnet40_zero_counts_name_the_key_not_the_root(tmp_path, key, value):
    from catpose.datasets.modelnet40 import ModelNet40

    with pytest.raises(ConfigError) as info:
        ModelNet40(str(tmp_path), **{key: value})
    msg = one_line(info.value)
    assert f"dataset.{key}={value}" in msg and "root" not in msg


# ------------------------------------------------------------------ the output directory


def test_output_root_that_is_a_file(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    with pytest.raises(RunAborted) as info:
        run(toy_cfg(tmp_path, output_root=blocker))
    msg = one_line(info.value)
    assert str(blocker) in msg and "set output_root=" in msg


@pytest.mark.parametrize(
    "code, needle", [(errno.EACCES, "not writable"), (errno.EROFS, "not writable"), (errno.ENOSPC, "the disk is full")]
)
def test_unwritable_or_full_output_directory_aborts_without_recording(tmp_path, monkeypatch, code, needle):
    """Tests run as root here, so a read-only folder cannot be made with chmod: the OSError is
    injected where the runner writes a sample (as a full disk would raise it)."""

    out = rundir.run_dir_for(toy_cfg(tmp_path))
    real = rundir.SampleWriter.write

    def write(self, row):
        if row["sample_id"].endswith("v2"):
            raise OSError(code, os.strerror(code))
        real(self, row)

    monkeypatch.setattr(rundir.SampleWriter, "write", write)
    with pytest.raises(RunAborted) as info:
        run(toy_cfg(tmp_path))
    msg = one_line(info.value)
    assert needle in msg and str(out) in msg and "set output_root=" in msg
    assert [r["sample_id"] for r in read_rows(out / "samples.jsonl")] == ["block/0/v0", "block/0/v1"]
    monkeypatch.setattr(rundir.SampleWriter, "write", real)
    run(toy_cfg(tmp_path))  # with space again, the re-run finishes the rest
    assert len(read_rows(out / "samples.jsonl")) == 3


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder anyway")
def test_read_only_output_root_for_real(tmp_path):
    root = tmp_path / "ro"
    root.mkdir()
    root.chmod(0o555)
    try:
        with pytest.raises(RunAborted) as info:
            run(toy_cfg(tmp_path, output_root=root))
    finally:
        root.chmod(0o755)
    assert "not writable" in one_line(info.value) and str(root) in str(info.value)


def test_read_only_output_root_when_creating_the_run_directory(tmp_path, monkeypatch):
    def mkdir(self, *args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(self))

    monkeypatch.setattr(Path, "mkdir", mkdir)
    with pytest.raises(RunAborted) as info:
        run(toy_cfg(tmp_path))
    assert "not writable" in one_line(info.value)


# ------------------------------------------------------------------ two runs, one run directory


def _hold_lock(run_dir: Path, pid: str) -> int:
    run_dir.mkdir(parents=True, exist_ok=True)
    fd = os.open(run_dir / LOCK_FILE, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    os.ftruncate(fd, 0)
    os.write(fd, f"{pid}\n".encode())
    return fd


def test_a_held_run_directory_fails_in_one_line_naming_the_holder(tmp_path):
    out = run(toy_cfg(tmp_path))
    fd = _hold_lock(out, "4242")
    try:
        for timeout in (0, 0.3):
            with pytest.raises(RunAborted) as info:
                run(toy_cfg(tmp_path, [f"lock_timeout={timeout}"]))
            msg = one_line(info.value)
            assert "in use by pid 4242" in msg and str(out) in msg
    finally:
        os.close(fd)
    assert len(read_rows(out / "samples.jsonl")) == 3  # the refused runs did nothing (no row twice)


def test_a_second_run_waits_then_skips_what_the_first_did(tmp_path, capsys, caplog):
    out = run(toy_cfg(tmp_path))
    (out / "samples.jsonl").unlink()
    fd = _hold_lock(out, "4242")

    def first_run_finishes():  # what the holder would have written, then its exit
        run(toy_cfg(tmp_path / "elsewhere"))  # (a separate directory: the lock is per directory)
        rows = read_rows(next((tmp_path / "elsewhere" / "out").glob("*/*/*")) / "samples.jsonl")
        with open(out / "samples.jsonl", "w") as f:
            f.writelines(json.dumps(r) + "\n" for r in rows)
        os.close(fd)

    timer = threading.Timer(1.0, first_run_finishes)
    timer.start()
    try:
        run(toy_cfg(tmp_path))
    finally:
        timer.join()
    # on stderr where an earlier command configured catpose's log handler, else in pytest's capture
    assert "waiting for pid 4242" in capsys.readouterr().err + caplog.text
    assert json.loads((out / "run.json").read_text())["n_run_now"] == 0
    assert len(read_rows(out / "samples.jsonl")) == 3


@pytest.mark.slow
def test_two_bench_runs_into_one_directory_do_each_sample_once(tmp_path):
    args = [
        *BENCH,
        "run",
        "method=icp",
        "dataset=synthetic",
        "dataset.categories=[car]",
        "dataset.instances_per_category=1",
        "dataset.views_per_instance=2",
        "progress=false",
        f"output_root={tmp_path}",
    ]
    procs = [
        subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    results = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [e[-2000:] for _, e in results]
    assert sum("waiting for pid" in e for _, e in results) == 1, [e for _, e in results]
    run_dir = next(tmp_path.glob("synthetic-gt_model/icp/*"))
    rows = read_rows(run_dir / "samples.jsonl")
    assert sorted(r["sample_id"] for r in rows) == ["car/000/v00", "car/000/v01"]


# ------------------------------------------------------------------ end to end through bench run


def _bench(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, HYDRA_FULL_ERROR="0")
    return subprocess.run(
        [*BENCH, "run", f"output_root={tmp_path / 'out'}", "progress=false", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        env=env,
    )


def test_bench_run_bad_limit_gives_one_line(tmp_path):
    r = _bench(tmp_path, "limit=-1")
    assert r.returncode == 2 and r.stderr.strip() == (
        "bench run: error: limit=-1 is not an integer >= 1; set limit=<integer >= 1> (or drop it)"
    ), r.stderr


CASES = {  # name -> (args, needle); the files are written by _prepare
    "limit=abc": (["limit=abc"], "limit='abc' is not an integer"),
    "seed=1.5": (["seed=1.5"], "seed=1.5 is not an integer"),
    "lr=abc": (
        ["method=ours", "method.optimiser.lr=abc"],
        "method.optimiser.lr='abc' must be a positive number",
    ),
    "no root": (["dataset=bop"], "e.g. dataset.root=<value>"),
    "bop fx<0": (["dataset=bop", "dataset.root={bop_fx}"], "fx=-300, fy=300"),
    "bop no obj_id": (["dataset=bop", "dataset.root={bop_gt}"], "has no integer obj_id"),
    "redwood fx=0": (["dataset=redwood", "dataset.root={tmp}", "dataset.fx=0"], "dataset.fx=0 must be a positive"),
    "views=0": (
        ["dataset=modelnet40", "dataset.root={tmp}", "dataset.views_per_instance=0"],
        "dataset.views_per_instance=0 must be an integer >= 1",
    ),
    "off 2 coords": (
        [
            "dataset=modelnet40",
            "dataset.root={mn}",
            "dataset.categories=[box]",
            "dataset.templates={{}}",
            "limit=1",
            "method=icp",
        ],
        None,
    ),
    "output_root file": (["output_root={tmp}/a_file", "limit=1"], "a file is in the way"),
}


def _prepare(tmp_path: Path) -> dict[str, str]:
    write_bop(tmp_path / "bop_fx", cam_K=(-300.0, 0, 159.5, 0, 300.0, 119.5, 0, 0, 1))
    write_bop(tmp_path / "bop_gt", gt_entry={"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1]})
    write_off(tmp_path / "mn" / "box" / "train" / "box_0001.off", ["0 0 0", "1 0", "0 1 0"])
    (tmp_path / "a_file").write_text("")
    return {
        "tmp": str(tmp_path),
        "bop_fx": str(tmp_path / "bop_fx"),
        "bop_gt": str(tmp_path / "bop_gt"),
        "mn": str(tmp_path / "mn"),
    }


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_bench_run_gives_one_line(tmp_path, case):
    args, needle = CASES[case]
    paths = _prepare(tmp_path)
    r = _bench(tmp_path, *[a.format(**paths) for a in args])
    assert "Traceback" not in r.stderr, r.stderr[-3000:]
    if needle is None:  # a bad sample file: that sample fails with a one-line message, the run goes on
        assert r.returncode == 0, r.stderr[-3000:]
        row = read_rows(next((tmp_path / "out").glob("*/*/*")) / "samples.jsonl")[0]
        assert row["status"] == "failed" and "box_0001.off cannot be read as a mesh" in row["error"], row
        return
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and needle in lines[0], r.stderr[-3000:]


def test_other_constructor_errors_name_the_group_and_the_key_they_mention():
    # a target without readable annotations that raises a plain TypeError naming its argument
    node = OmegaConf.create({"name": "span", "_target_": "datetime.timedelta", "days": "abc"})
    with pytest.raises(ConfigError) as info:
        build_from_config(node, "method")
    msg = one_line(info.value)
    assert "cannot build method 'span'" in msg and "check method.days='abc'" in msg, msg
