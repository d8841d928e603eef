"""``bench data check dataset=NAME dataset.root=PATH``: is a dataset root laid out as its loader expects?

Walks the layout with the loader's own code (the dataset built as ``bench run`` builds it, then
its :meth:`~catpose.datasets.dataset.ObjectDataset.check_layout`) in seconds, then loads the
first sample. Prints one ``problem:`` line per problem with its fix and exits 2 when there is
any; ``warning:`` lines only limit some protocols (exit 0). Layouts and downloads: docs/data.md.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Any

from catpose.datasets.layout_check import LayoutReport
from catpose.errors import CatposeError, ConfigError, one_line

_USAGE = """usage: bench data check dataset=NAME dataset.root=PATH [dataset.KEY=VALUE ...]

Check that a dataset root has the layout its loader expects (docs/data.md), in seconds: prints one
line per problem with the fix and exits 2 when there is any, 0 when the root is good."""


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help") or any(a in ("-h", "--help") for a in argv):
        print(_USAGE)
        return 0
    if argv[0] != "check":
        raise ConfigError(f"unknown data command {argv[0]!r}; use: bench data check dataset=NAME dataset.root=PATH")
    overrides = argv[1:]
    if not any(a.split("=", 1)[0].lstrip("+~") == "dataset" for a in overrides):
        raise ConfigError("name the dataset: bench data check dataset=NAME dataset.root=PATH")
    from catpose.bench.run.config import compose

    t0 = time.perf_counter()
    node = compose(overrides).dataset  # as `bench run` composes it (one-line errors)
    name = str(node.get("name", "dataset"))
    report = check(name, node)
    for line in report.problems:
        print(f"problem: {line}")
    if report.problems:
        return 2
    for line in report.warnings:
        print(f"warning: {line}")
    for line in report.facts:
        print(f"ok: {line}")
    where = f" root={node.root}" if "root" in list(node.keys()) else ""
    print(f"bench data check: dataset={name}{where} is good ({time.perf_counter() - t0:.1f} s)")
    return 0


def check(name: str, node: Any) -> LayoutReport:
    """Check the dataset of config ``node`` (the composed ``dataset`` group)."""
    from omegaconf import OmegaConf

    from catpose.bench.run.build import build_from_config, target_class

    report = LayoutReport()
    generated = getattr(target_class(node), "generated", None)
    if generated:
        report.facts.append(f"dataset={name} is {generated}")
        return report
    if "root" in list(node.keys()) and OmegaConf.is_missing(node, "root"):
        report.problem(f"dataset.root is not set: bench data check dataset={name} dataset.root=PATH")
        return report
    root = Path(str(node.root))
    if not root.is_dir():
        report.problem(f"{root} is not a folder: set dataset.root to the unpacked dataset (docs/data.md)")
        return report
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, dataset = build_from_config(node, "dataset")
    except CatposeError as e:
        report.problem(f"{e}")
        return report
    dataset.check_layout(name, report)
    if not report.problems:
        _check_loader(dataset, report)
    return report


def _check_loader(dataset: Any, report: LayoutReport) -> None:
    """The loader's own sample list, and its first sample loaded (what ``bench run`` does first)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            ids = dataset.observation_ids()
            obs = dataset.observation(ids[0])
        except CatposeError as e:
            report.problem(str(e))
            return
        except Exception as e:  # noqa: BLE001 - a malformed file surfaces as anything; name it
            report.problem(f"loading the first sample failed: {one_line(e)}")
            return
    report.warnings += [" ".join(str(w.message).split()) for w in caught]
    report.facts.append(f"{len(ids)} samples; the first ({ids[0]}) loads with {len(obs.points_camera)} points")
