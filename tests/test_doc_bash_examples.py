"""Every ``bench`` example in the README's and docs' bash blocks and in ``bench <command> --help``.

Each example is either run or skipped for a stated reason (shared data, a placeholder, an
optional plugin, a committed file it would rewrite, a command another test runs). The default
suite checks that every ``bench run`` example that can run composes (the checks ``bench run``
makes before Hydra starts); the slow test runs every runnable example in a scratch folder, in
the order the docs give them, each ``bench run`` with ``limit=2`` added so that it takes seconds.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]

#: (pattern, why the example is not run here); the first that matches decides
SKIPS: list[tuple[str, str]] = [
    (r"dataset\.root=|--root |/data/|\.\./shared/|bench (suite|clutter|data check)\b", "needs the shared real data"),
    (r"<[a-z]+>|\.\.\.|\[--", "a placeholder to fill in"),
    (
        r"airplane\.csv|rpmnet|sample_ids\.txt|outputs/ext/|outputs/ycbv-|outputs/modelnet40-",
        "needs files made elsewhere",
    ),
    (r"--out results/|--update|--write-inputs|--write results/", "rewrites a committed results/ file"),
    (r"hydra/launcher=(?!basic)", "needs a launcher of the cluster extra (tests/test_scaleout.py runs them)"),
    (r"^bench regress", "the regression gate: tests/test_regress.py runs it on its suites"),
    (r"^bench perf", "timing: tests/test_perf.py runs bench perf on small problems"),
]


def _bash_examples(path: Path) -> list[str]:
    """Command lines starting with ``bench`` in the file's bash blocks (continuations joined,
    trailing comments dropped)."""
    out = []
    for block in re.findall(r"```(?:bash|sh|shell|console)\n(.*?)```", path.read_text(), re.S):
        lines = block.splitlines()
        k = 0
        while k < len(lines):
            line = lines[k].strip()
            while line.endswith("\\") and k + 1 < len(lines):
                k += 1
                line = line[:-1].rstrip() + " " + lines[k].strip()
            k += 1
            line = re.sub(r"^\$ ", "", line)
            if re.match(r"(bench|catpose) ", line):
                out.append(re.sub(r"\s+#.*$", "", line).strip())
    return out


def _help_examples() -> list[tuple[str, str]]:
    """``(source, line)`` of the lines starting with ``bench`` in ``bench --help`` and each
    ``bench <command> --help`` (in this process: the CLI imports a command only when it runs)."""
    import contextlib
    import io

    from catpose.bench.cli import COMMANDS, main

    out = []
    for command in ["", *COMMANDS]:
        text = io.StringIO()
        with contextlib.redirect_stdout(text), pytest.MonkeyPatch.context() as mp:
            mp.setenv("COLUMNS", "200")
            try:
                main([command, "--help"] if command else ["--help"])
            except SystemExit:  # argparse's --help
                pass
        for line in text.getvalue().splitlines():
            if re.match(r"\s+(bench|catpose) ", line):
                out.append((f"bench {command} --help".replace("  ", " "), re.sub(r"\s+#.*$", "", line).strip()))
    return out


def all_examples() -> list[tuple[str, str]]:
    examples = [(p.relative_to(REPO).as_posix(), c) for p in DOCS for c in _bash_examples(p)]
    return examples + _help_examples()


def skip_reason(command: str) -> str | None:
    for pattern, why in SKIPS:
        if re.search(pattern, command):
            return why
    return None


@pytest.fixture(scope="module")
def examples() -> list[tuple[str, str]]:
    return all_examples()


def test_examples_are_found_and_most_run(examples):
    runnable = [c for _, c in examples if skip_reason(c) is None]
    assert len(examples) >= 40 and len(runnable) >= 11, runnable
    assert any("--help" in source for source, _ in examples)  # the help texts' examples are in


def test_every_runnable_bench_run_example_composes(examples):
    from catpose.bench.run.config import check_run_args

    checked = 0
    for _source, command in examples:
        words = shlex.split(command)
        if skip_reason(command) is None and words[1] == "run":
            check_run_args(words[2:])  # raises ConfigError, one line, for an example that would fail
            checked += 1
    assert checked >= 8


def _runnable(command: str) -> str:
    """The example as run here: ``bench run`` with ``limit=2`` (seconds, not minutes)."""
    words = shlex.split(command)
    quick = not {"--cfg", "--info", "-sc"} & set(words) and not any(w.startswith("limit=") for w in words)
    if words[1] == "run" and quick:
        words.append("limit=2")
    words[0] = "bench"
    return " ".join(shlex.quote(w) if not re.search(r"[*]", w) else w for w in words)


@pytest.mark.slow
def test_every_runnable_example_runs(examples, tmp_path):
    bindir = Path(sys.executable).parent
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}", HYDRA_FULL_ERROR="0")
    failures = []
    for source, command in examples:
        if skip_reason(command) is not None:
            continue
        r = subprocess.run(
            ["bash", "-c", _runnable(command)], capture_output=True, text=True, timeout=1200, cwd=tmp_path, env=env
        )
        if r.returncode != 0:
            failures.append(f"{source}: {command}: exit {r.returncode}: {r.stderr.strip()[-400:]}")
    assert not failures, "\n".join(failures)
