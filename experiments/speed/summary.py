"""The speed tables the docs quote, made from ``bench perf``'s and the GPU check's CSVs.

    python experiments/speed/summary.py [--dir results/perf]

reads ``perf_<set>.csv`` and ``perf_<set>_stages.csv`` (``bench perf --out results/perf/perf_<set>.csv``)
and ``gpu_solver_*.csv`` (``experiments/speed/gpu.py --out``) in ``--dir`` and writes there:

- ``speed.md``: per problem set and method, the threads it ran on (``bench perf --threads``: ours'
  compiled kernels and torch), the median and 90th-percentile seconds per registration, the
  ratio to FGR's median in the same run, the load average before and after and the process's
  peak RSS;
- ``stages.md``: ours' stages, median seconds, one column per problem set;
- ``gpu.md``: the solver alone per device and batch (ms per problem, largest rotation
  difference to the CPU float64 solver).

Nothing is measured here; every figure is a CSV's, rounded.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from catpose.errors import DatasetError


def _sets(folder: Path) -> list[str]:
    return sorted(
        p.stem[len("perf_") :] for p in folder.glob("perf_*.csv") if not p.stem.endswith(("_stages", "_times"))
    )


def _threads(value: object) -> str:
    """A CSV's ``threads`` cell: the count, or ``-`` where there is none (no column, an empty cell)."""
    if isinstance(value, (int, float)) and value == value:  # NaN != NaN: an empty cell
        return str(int(value))
    return "-"


def speed_table(folder: Path) -> str:
    """``speed.md``'s Markdown (see the module docstring)."""
    import pandas as pd

    lines = [
        "**Seconds per registration** (`bench perf`, interleaved rounds; "
        "median and 90th percentile of the timed calls; a method label names a config, e.g. `adam` = ours with `method.optimiser.solver=adam`)",
        "",
        "| problems | method | threads | timed calls | median s | p90 s | median / FGR's | load before / after | CPUs "
        "| peak RSS MiB |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name in _sets(folder):
        df = pd.read_csv(folder / f"perf_{name}.csv")
        for r in df.to_dict("records"):
            lines.append(
                f"| {r['source']} | {r['method']} | {_threads(r.get('threads'))} | {int(r['n'])} | {r['median_s']:.3f} | "
                f"{r['p90_s']:.3f} | {r['ratio_to_fgr']:.2f} | {r['load_before']:.2f} / {r['load_after']:.2f} | "
                f"{int(r['cpus'])} | {r['peak_rss_mb']:.0f} |"
            )
    return "\n".join(lines) + "\n"


def stages_table(folder: Path) -> str:
    """``stages.md``'s Markdown: ours' stages (median s) per problem set."""
    import pandas as pd

    frames = {}
    for name in _sets(folder):
        path = folder / f"perf_{name}_stages.csv"
        if path.is_file():
            df = pd.read_csv(path)
            frames[name] = df[df["method"] == "ours"].set_index("stage")["median_s"]
    if not frames:
        return ""
    stages = list(dict.fromkeys(s for f in frames.values() for s in f.index))
    lines = [
        "**Ours by stage** (median seconds per registration, `bench perf`)",
        "",
        "| stage | " + " | ".join(frames) + " |",
        "|---|" + "---:|" * len(frames),
    ]
    for s in stages:
        cells = [f"{frames[n][s]:.4f}" if s in frames[n].index else "-" for n in frames]
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def gpu_table(folder: Path) -> str:
    """``gpu.md``'s Markdown: every ``gpu_solver_*.csv`` row."""
    import pandas as pd

    lines = []
    for path in sorted(folder.glob("gpu_solver_*.csv")):
        df = pd.read_csv(path)
        if not lines:
            lines = [
                "**The solver alone** (`experiments/speed/gpu.py`: ours' candidates solved in one launch; "
                "rotation difference to the CPU float64 solver)",
                "",
                "| file | device | problems per launch | ms per problem | max rotation difference (deg) | dtype | torch |",
                "|---|---|---:|---:|---:|---|---|",
            ]
        for r in df.to_dict("records"):
            lines.append(
                f"| {path.name} | {r['name']} | {int(r['batch'])} | {r['ms_per_problem']:.2f} | "
                f"{r['max_rot_diff_deg_vs_cpu64']:g} | {r['dtype']} | {r['torch']} |"
            )
    return "\n".join(lines) + "\n" if lines else ""


def write_tables(folder: Path) -> list[Path]:
    """Write the tables that have data into ``folder``; returns their paths."""
    if not folder.is_dir() or not _sets(folder) and not list(folder.glob("gpu_solver_*.csv")):
        raise DatasetError(
            f"{folder} has no perf_<set>.csv or gpu_solver_*.csv; run `bench perf --out {folder}/perf_<set>.csv` first"
        )
    written = []
    for name, text in (
        ("speed.md", speed_table(folder) if _sets(folder) else ""),
        ("stages.md", stages_table(folder)),
        ("gpu.md", gpu_table(folder)),
    ):
        if text:
            from catpose import atomic

            atomic.write_text(folder / name, text)
            written.append(folder / name)
    return written


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python experiments/speed/summary.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", type=Path, default=Path("results/perf"))
    args = ap.parse_args(argv)
    for path in write_tables(args.dir):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    import sys

    from catpose.errors import CatposeError, command_error

    try:
        sys.exit(main())
    except CatposeError as e:
        print(command_error("perf summary", e), file=sys.stderr)
        sys.exit(2)
