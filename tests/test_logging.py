"""Logging: catpose's modules log through ``logging`` (no prints in the library), the CLI writes
each record as one line on stderr, and ``log_level=`` / Hydra's ``hydra.verbose`` set how much."""

from __future__ import annotations

import ast
import logging
from pathlib import Path

import pytest

from catpose import logs
from catpose.errors import ConfigError

REPO = Path(__file__).resolve().parents[1]
TINY = [
    "method=icp",
    "dataset=synthetic",
    "dataset.categories=[car]",
    "dataset.instances_per_category=1",
    "dataset.views_per_instance=1",
    "method.num_starts=2",
    "progress=false",
    "print_summary=false",
]


@pytest.fixture(autouse=True)
def _restore_catpose_logger():
    logger = logging.getLogger(logs.ROOT)
    saved = (list(logger.handlers), logger.level, logger.propagate)
    yield
    logger.handlers[:], logger.level, logger.propagate = saved[0], saved[1], saved[2]


def test_one_line_per_record_in_the_cli_format(capsys):
    logs.configure("run", "DEBUG")
    log = logging.getLogger("catpose.bench.run.runner")
    log.info("started %d", 3)
    log.warning("sample %s failed: %s", "a/1", "bad")
    log.debug("detail")
    logging.getLogger("catpose.x").error("broken")
    assert capsys.readouterr().err.splitlines() == [
        "bench run: started 3",
        "bench run: warning: sample a/1 failed: bad",
        "bench run: debug: [catpose.bench.run.runner] detail",
        "bench run: error: broken",
    ]
    logs.configure("table", "WARNING")  # replaces the handler, does not add a second one
    log.info("hidden")
    log.warning("shown")
    assert capsys.readouterr().err == "bench table: warning: shown\n"
    assert sum(isinstance(h, logs._StderrHandler) for h in logging.getLogger("catpose").handlers) == 1


def test_levels_of_a_run():
    logs.configure("run")
    assert logs.configure_run("warning") == logging.WARNING
    assert logs.configure_run("ERROR", verbose=True) == logging.DEBUG  # hydra.verbose=true
    assert logs.configure_run("ERROR", verbose=["catpose"]) == logging.DEBUG  # hydra.verbose=catpose
    assert logs.configure_run("ERROR", verbose="torch") == logging.ERROR
    with pytest.raises(ConfigError, match="log_level=loud is not a log level; use one of DEBUG, INFO"):
        logs.configure_run("loud")
    logs.configure_run("INFO", hydra_logging=True)  # hydra/job_logging=default: Hydra's handlers take the records
    logger = logging.getLogger("catpose")
    assert logger.propagate and not any(isinstance(h, logs._StderrHandler) for h in logger.handlers)


def _run(capsys, tmp_path: Path, *extra: str) -> tuple[int, str]:
    from catpose.bench.cli import main

    code = main(["run", *TINY, f"output_root={tmp_path}", *extra])
    return code, capsys.readouterr().err


def test_log_level_and_hydra_verbose_in_bench_run(tmp_path: Path, capsys):
    code, err = _run(capsys, tmp_path, "hydra.verbose=true")
    assert code == 0, err
    assert "bench run: debug: [catpose.bench.run.runner] sample car/000/v00: ok, error " in err
    assert "1 samples, 0 done before, 1 to run" in err
    run_dirs = list(tmp_path.glob("*/*/*"))
    code, err = _run(capsys, tmp_path, "log_level=WARNING")  # resumes: nothing to run, nothing to say
    assert code == 0 and err == "", err
    code, err = _run(capsys, tmp_path, "log_level=INFO")  # the default: a clean run says nothing on stderr
    assert code == 0 and err == "", err
    assert list(tmp_path.glob("*/*/*")) == run_dirs  # the log level is not part of the run directory's name
    code, err = _run(capsys, tmp_path, "log_level=DEBUG", "seed=1")
    assert code == 0 and "debug: [catpose.bench.run.runner] sample car/000/v00: ok" in err, err
    assert "1 samples, 0 done before, 1 to run" in err


def test_no_print_in_methods_datasets_and_the_core():
    """The library logs; only commands print their results (bench/: tables, regress's report; a
    module's command: its ``main()`` or ``if __name__ == "__main__":`` block, such as
    ``python -m catpose.open3d_libusb``)."""

    def is_main_block(node: ast.AST) -> bool:  # a module's command: its main() or its __main__ block
        if isinstance(node, ast.FunctionDef) and node.name == "main":
            return True
        return (
            isinstance(node, ast.If) and "__main__" in ast.unparse(node.test) and "__name__" in ast.unparse(node.test)
        )

    found = []
    for folder in ("methods", "datasets", "src/catpose"):
        for path in sorted((REPO / folder).rglob("*.py")):
            tree = ast.parse(path.read_text())
            library = [n for n in tree.body if not is_main_block(n)]
            for node in (n for top in library for n in ast.walk(top)):
                if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
                    found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert found == []
