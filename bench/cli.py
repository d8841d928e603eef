"""The ``bench`` command line.

Each command lives in its own module and is imported only when it runs, so ``bench --help``
answers instantly (no torch, Open3D or Hydra import).
"""

from __future__ import annotations

import importlib
import sys
import warnings
from pathlib import Path

# command, module under catpose.bench, function, one-line help
_TABLE = (
    ("run", "run.command", "main", "run a method on a dataset: bench run method=ours dataset=synthetic [-m sweeps]"),
    ("evaluate", "run.evaluate", "main", "recompute errors and summaries of run directories from their files"),
    ("table", "report.table_command", "main", "the paper's tables (Markdown, LaTeX, CSV) from run directories"),
    ("report", "report.report_folder", "main", "tables and plots of run directories in one folder"),
    ("perf", "perf.registration", "main", "seconds per registration and per stage for ours and ICP"),
    ("templates", "category.template_medoids", "main", "choose K category templates by K-medoids over F-score"),
    ("export", "interop.bop_export", "main", "export a run's estimates as a BOP results CSV"),
    ("score", "interop.score", "main", "score an external predictions file (BOP CSV or per-sample CSV)"),
    ("suite", "real.suite", "main", "every method on the shared real data, one table: bench suite real"),
    ("clutter", "real.suite", "clutter_main", "generate the cluttered synthetic set ahead and print its folder"),
    (
        "data",
        "run.data_check",
        "main",
        "check a dataset root before a run: bench data check dataset=NAME dataset.root=PATH",
    ),
    ("regress", "regress.run_suites", "main", "CI regression: small subsets against committed reference metrics"),
)
COMMANDS: dict[str, tuple[str, str, str]] = {
    name: (f"catpose.bench.{module}", function, help_) for name, module, function, help_ in _TABLE
}


def _usage() -> str:
    width = max(map(len, COMMANDS))
    lines = [
        "usage: bench <command> [args]",
        "",
        "Category-level camera pose estimation benchmark (catpose).",
        "",
        "commands:",
    ]
    lines += [f"  {name:<{width}}  {help_}" for name, (_, _, help_) in COMMANDS.items()]
    lines += [
        "",
        "Run `bench <command> --help` for a command's options. Examples:",
        "  bench run method=icp dataset=synthetic",
        "  bench run -m method=icp,ours dataset=synthetic protocol=gt_model,templates",
        "  bench run method=ours dataset=modelnet40 dataset.root=/data/ModelNet40",
    ]
    return "\n".join(lines)


def _one_line_catpose_warnings() -> None:
    """Show catpose's own warnings (e.g. an object missing from models_info.json) as one line,
    ``bench: warning: <message>``; other libraries' warnings keep Python's format."""
    package = Path(__file__).resolve().parents[1]
    default = warnings.formatwarning

    def formatwarning(message, category, filename, lineno, line=None):  # noqa: ANN001 - warnings' signature
        if Path(filename).resolve().is_relative_to(package) and ".venv" not in Path(filename).parts:
            return f"bench: warning: {message}\n"
        return default(message, category, filename, lineno, line)

    warnings.formatwarning = formatwarning


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    _one_line_catpose_warnings()
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0
    if argv[0] in ("-V", "--version"):
        from catpose import __version__

        print(f"catpose {__version__}")
        return 0
    name = argv[0]
    if name not in COMMANDS:
        print(
            f"bench: error: unknown command {name!r}; choose one of: {', '.join(COMMANDS)} (see bench --help)",
            file=sys.stderr,
        )
        return 2
    module_name, func_name, _ = COMMANDS[name]
    from catpose import logs
    from catpose.errors import CatposeError, command_error

    logs.configure(name)  # catpose's loggers: one line each on stderr, "bench <name>: ..." (bench run: log_level=)

    try:
        func = getattr(importlib.import_module(module_name), func_name)
        return int(func(argv[1:]) or 0)
    except CatposeError as e:  # every command's user errors: one line, exit status 2
        print(command_error(name, e), file=sys.stderr)
        return 2
    except ImportError as e:  # an optional extra this command needs (torch, POT): one line naming it
        from catpose.extras import missing_extra

        missing = missing_extra(e)
        if missing is None:
            raise
        print(command_error(name, missing), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            f"bench {name}: interrupted; finished samples are saved, re-run the same command to resume", file=sys.stderr
        )
        return 130


if __name__ == "__main__":
    sys.exit(main())
