"""One output rule for every command (issue 42; docs/file-safety.md, bench/run/overwrite.py).

Every command that writes where it is told (``--out``, ``--sheet``, ``--write``) is run against
seven targets: its own input, a parent of it, a child of it, an existing file, an existing folder,
a read-only folder and a full disk. An input is never written (not even with ``--force``); an
existing target needs ``--force``; a file never replaces a folder nor a folder a file; a
read-only folder and a full disk are one line, exit 2, with nothing left behind. The full disk
is real: the command runs in a child process under ``RLIMIT_FSIZE`` (``ulimit -f``).
"""

from __future__ import annotations

import contextlib
import os
import resource
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from catpose.bench.cli import main as bench

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
sys.path.insert(0, str(TESTS))
from _study import run_study  # noqa: E402


@dataclass(frozen=True)
class Command:
    """How to run one command with its target ``out``: ``argv(world, out)``; ``kind`` of target;
    ``name`` of a file target; ``input`` of the command in the world (None: it reads no file)."""

    argv: Callable[[dict, Path], list[str]]
    kind: str
    name: str
    input: Callable[[dict], Path] | None
    module: str = "catpose.bench.cli"  # python -m <module> in the child process (a path ending .py: python <script>)
    old: str = "old\n"  # what an existing file target holds (a file the command may replace)
    needles: tuple[tuple[str, str], ...] = ()  # (situation, refusal) where it is not the input's


def _align(w: dict) -> list[str]:
    return ["dataset=modelnet40", f"dataset.root={w['mn40']}", "dataset.categories=[thing]"]


ALIGN_TAIL = ["dataset.split=train", "--category", "thing", "--points", "200", "--no-refine"]

COMMANDS = {
    "table": Command(lambda w, o: ["table", str(w["run"]), "--out", str(o)], "file", "t.md", lambda w: w["run"]),
    "report": Command(
        lambda w, o: ["report", str(w["run"]), "--out", str(o), "--no-pdf"], "folder", "rep", lambda w: w["run"]
    ),
    "export": Command(
        lambda w, o: ["export", str(w["bop_run"]), "--out", str(o)], "file", "m_toy-test.csv", lambda w: w["bop_run"]
    ),
    "score": Command(
        lambda w, o: ["score", str(w["preds"]), "--gt", str(w["run"]), "--method", "m", "--out", str(o)],
        "folder",
        "scored",
        lambda w: w["run"],
    ),
    "align": Command(
        lambda w, o: [*_align(w), *ALIGN_TAIL, "--compare", str(w["verified"]), "--out", str(o)],
        "file",
        "a.csv",
        lambda w: w["verified"],
        module="experiments/alignment/align.py",
        old="category,instance_id,yaw_deg\nthing,thing_0001,0\n",
    ),
    "align --sheet": Command(
        lambda w, o: [*_align(w), *ALIGN_TAIL, "--out", str(o.with_name("sheet_table.csv")), "--sheet", str(o)],
        "file",
        "s.png",
        lambda w: w["verified"].with_suffix(".png"),  # a verified table's picture
        module="experiments/alignment/align.py",
        needles=(
            ("own input", "is the contact sheet of"),
            ("a parent", "is not a picture file name"),
            ("a child", "is a file, not a folder"),
        ),
    ),
    "templates": Command(
        lambda w, o: ["templates", "dataset=synthetic", "--category", "mug", "--k", "2", "--out", str(o)],
        "file",
        "t.yaml",
        None,
        old="mug: [old]\n",
    ),
    "suite --write": Command(
        lambda w, o: [
            "suite",
            "real",
            "--table-only",
            "--sets",
            "ycbv",
            "--methods",
            "icp",
            "--output-root",
            str(w["runs"]),
            "--write",
            str(o),
        ],  # fmt: skip
        "file",
        "s.md",
        lambda w: w["run"],
    ),
    "why_wrong": Command(
        lambda w, o: [str(w["trun"]), "--out", str(o), "--wrong-deg", "1000"],  # the toy's views: none wrong
        "file",
        "w.md",
        lambda w: w["trun"],
        module="experiments/_lib/why_wrong.py",
    ),
    "ambiguity": Command(
        lambda w, o: [str(w["run"]), "--out", str(o), "--wrong-deg", "1000"],
        "file",
        "a.md",
        lambda w: w["run"],
        module="experiments/_lib/ambiguity.py",
    ),
}


def _entry(module: str) -> list[str]:
    """How a child process runs ``module``: a study's script by its path, a module with ``-m``."""
    return [str(REPO / module)] if module.endswith(".py") else ["-m", module]


def call(command: str, argv: list[str], capsys) -> tuple[int, str]:
    """Run in-process; (exit status, the one error line, checked to be one line)."""
    module = COMMANDS[command].module
    if module == "catpose.bench.cli":
        rc = bench(argv)
    elif module.endswith(".py"):  # a study's script (experiments/), run as a module namespace
        rc = run_study(module)["main"](argv)
    else:
        import importlib

        rc = importlib.import_module(module).main(argv)
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and "warning" not in ln]
    if rc != 0:
        assert len(err) == 1, err
        assert "Traceback" not in err[0]
    return rc, (err[0] if err else "")


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> dict:
    """The inputs every command reads: a toy run of each protocol (the runner's, so that commands
    that rebuild a run's parts can), predictions for it, a verified alignment table with its
    picture and the ModelNet40 folder of its shapes, and an empty shared-data folder."""
    from test_alignment import l_shape_mesh, write_off
    from test_bad_inputs import toy_cfg

    from catpose.bench.run.rundir import read_rows
    from catpose.bench.run.runner import run

    root = tmp_path_factory.mktemp("world")
    out = run(toy_cfg(root, output_root=root / "runs"))
    templates = run(toy_cfg(root, ["protocol=templates"], output_root=root / "runs"))
    lines = ["sample_id,R,t"]
    for r in read_rows(out / "samples.jsonl"):
        T = r["T_est"]
        lines.append(f"{r['sample_id']},{' '.join(map(str, T[:3] + T[4:7] + T[8:11]))},{T[3]} {T[7]} {T[11]}")
    (root / "preds.csv").write_text("\n".join(lines) + "\n")
    v, f = l_shape_mesh()
    write_off(root / "ModelNet40/thing/train/thing_0001.off", v, f)
    write_off(root / "ModelNet40/thing/train/thing_0002.off", v * 3.0, f)
    align = root / "align"
    align.mkdir()
    verified = align / "thing.csv"
    verified.write_text(
        "category,instance_id,yaw_deg,verified,note\nthing,thing_0001,0,true,checked\nthing,thing_0002,0,true,checked\n"
    )
    verified.with_suffix(".png").write_bytes(b"the checked picture")
    (root / "shared").mkdir()
    from _trust import CFG, rows, with_bop_ids, write_run

    return {
        "bop_run": write_run(root / "bop_run", with_bop_ids(rows([5.0, 10.0])), CFG),
        "root": root,
        "runs": root / "runs",
        "run": out,
        "trun": templates,
        "preds": root / "preds.csv",
        "mn40": root / "ModelNet40",
        "verified": verified,
        "shared": root / "shared",
    }


@pytest.fixture(autouse=True)
def _env(world, monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))
    monkeypatch.setenv("CATPOSE_SHARED_DATA", str(world["shared"]))  # bench suite: every set skipped, fast


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` and its bytes (run locks aside: taking one writes its holder's pid)."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.suffix != ".lock"
    }


@contextlib.contextmanager
def read_only(folder: Path):
    """``folder`` made unwritable: mode 555, and for root (whom modes do not stop) the immutable
    attribute where the file system has one; skips the test when neither stops a write."""
    folder.chmod(0o555)
    immutable = os.geteuid() == 0 and shutil.which("chattr") is not None
    if immutable:
        immutable = subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode == 0
    try:
        probe = folder / ".probe"
        try:
            probe.write_text("x")
        except OSError:
            pass
        else:
            probe.unlink()
            pytest.skip("this machine writes into a read-only folder (root without chattr)")
        yield
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(folder)], capture_output=True)
        folder.chmod(0o755)


NAMES = list(COMMANDS)


@pytest.mark.parametrize("situation", ["own input", "a parent", "a child"])
@pytest.mark.parametrize("command", NAMES)
def test_no_command_writes_an_input_a_parent_or_a_child_of_it(command, situation, world, capsys):
    cmd = COMMANDS[command]
    if cmd.input is None:
        pytest.skip(f"{command} reads no file that its --out could name (dataset overrides only)")
    inp = cmd.input(world)
    out = {"own input": inp, "a parent": inp.parent, "a child": inp / cmd.name}[situation]
    before = snapshot(world["root"])
    for force in ([], ["--force"]):
        rc, line = call(command, cmd.argv(world, out) + force, capsys)
        assert rc == 2, line
        needle = {"own input": "itself", "a parent": "contains", "a child": "lies inside", **dict(cmd.needles)}
        assert needle[situation] in line, line
    assert snapshot(world["root"]) == before


@pytest.mark.parametrize("command", NAMES)
def test_an_existing_file_is_replaced_only_with_force(command, world, tmp_path, capsys):
    cmd = COMMANDS[command]
    out = tmp_path / cmd.name
    out.write_text(cmd.old)
    rc, line = call(command, cmd.argv(world, out), capsys)
    assert rc == 2 and ("exists; pass another" in line if cmd.kind == "file" else "is a file; pass a folder" in line)
    assert out.read_text() == cmd.old
    rc, line = call(command, cmd.argv(world, out) + ["--force"], capsys)
    if cmd.kind == "folder":  # a folder never replaces a file, not even with --force
        assert rc == 2 and "is a file; pass a folder" in line and out.read_text() == cmd.old
    else:
        assert rc == 0, line
        assert out.read_bytes() != cmd.old.encode()


@pytest.mark.parametrize("command", NAMES)
def test_an_existing_folder_is_replaced_only_with_force_and_only_by_a_folder(command, world, tmp_path, capsys):
    cmd = COMMANDS[command]
    out = tmp_path / cmd.name
    out.mkdir()
    (out / "old.txt").write_text("mine")
    rc, line = call(command, cmd.argv(world, out), capsys)
    assert rc == 2 and ("already holds 1 other file(s)" in line if cmd.kind == "folder" else "is a folder" in line)
    assert (out / "old.txt").read_text() == "mine"
    rc, line = call(command, cmd.argv(world, out) + ["--force"], capsys)
    if cmd.kind == "file":  # a file never replaces a folder
        assert rc == 2 and "is a folder" in line and (out / "old.txt").is_file()
    else:
        assert rc == 0, line
        assert not (out / "old.txt").exists() and any(out.iterdir())  # replaced whole, built aside
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # nothing left beside it


@pytest.mark.parametrize("command", NAMES)
def test_a_read_only_folder_is_one_line_and_nothing_is_written(command, world, tmp_path, capsys):
    cmd = COMMANDS[command]
    folder = tmp_path / "ro"
    folder.mkdir()
    with read_only(folder):
        rc, line = call(command, cmd.argv(world, folder / cmd.name), capsys)
        assert rc == 2 and ("not writable" in line or "cannot write" in line), line
        assert list(folder.iterdir()) == []


def _full_disk(limit: int) -> Callable[[], None]:
    def preexec() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return preexec


FAST_FULL_DISK = {"table", "report", "export", "score"}


@pytest.mark.parametrize(
    "command", [c if c in FAST_FULL_DISK else pytest.param(c, marks=pytest.mark.slow) for c in NAMES]
)
def test_a_full_disk_is_one_line_and_leaves_nothing(command, world, tmp_path):
    """``ulimit -f``: no file may grow past 64 bytes in the child process (writes fail with EFBIG,
    as on a full disk); the command says so in one line and leaves the folder as it was."""
    cmd = COMMANDS[command]
    (tmp_path / "keep.txt").write_text("x")
    env = dict(os.environ, CATPOSE_SHARED_DATA=str(world["shared"]), PYTHONPATH=str(TESTS))
    proc = subprocess.run(
        [sys.executable, *_entry(cmd.module), *cmd.argv(world, tmp_path / cmd.name)],
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=_full_disk(64),
        timeout=300,
    )
    err = [ln for ln in proc.stderr.splitlines() if "error" in ln]  # progress and info lines aside
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert len(err) == 1 and "the disk is full" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.txt"]  # no file, no half-built folder


def test_evaluate_into_a_read_only_run_directory_is_one_line(world, tmp_path, capsys):
    """It writes only a run's own files (summaries), atomically."""
    run = Path(shutil.copytree(world["run"], tmp_path / "run"))
    before = snapshot(run)
    with read_only(run):
        assert bench(["evaluate", str(run)]) == 2
        err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        assert len(err) == 1 and err[0].startswith("bench evaluate: error: cannot write the run directory"), err
    assert snapshot(run) == before


@pytest.mark.slow
def test_evaluate_on_a_full_disk_is_one_line_and_keeps_the_old_files(world, tmp_path):
    run = Path(shutil.copytree(world["run"], tmp_path / "run"))
    before = snapshot(run)
    proc = subprocess.run(
        [sys.executable, "-m", "catpose.bench.cli", "evaluate", str(run)],
        capture_output=True,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(TESTS)),
        preexec_fn=_full_disk(64),
        timeout=300,
    )
    err = [ln for ln in proc.stderr.splitlines() if "error" in ln]
    assert proc.returncode == 2 and len(err) == 1 and "the disk is full" in err[0], proc.stderr[-2000:]
    assert snapshot(run) == before
