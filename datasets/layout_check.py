"""What a dataset's :meth:`~catpose.datasets.dataset.ObjectDataset.check_layout` reports to ``bench
data check`` (:mod:`catpose.bench.run.data_check`), and the checks several datasets share: their
templates resolve, and at most three lines per kind of damaged file."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from catpose.errors import CatposeError


@dataclass
class LayoutReport:
    """Problems (the run would fail), warnings (some protocols would) and facts found."""

    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    facts: list[str] = field(default_factory=list)

    def problem(self, text: str) -> None:
        self.problems.append(text)

    def warn(self, text: str) -> None:
        self.warnings.append(text)

    def note_files(self, problems: list[str], kind: str) -> None:
        """The first problems of one kind of file, and how many more."""
        for line in problems[:3]:
            self.problem(line)
        if len(problems) > 3:
            self.problem(f"... and {len(problems) - 3} more {kind} like those")


def check_templates(dataset: Any, report: LayoutReport, instance_exists: Callable[[str, str], bool]) -> None:
    """Every configured template resolves: a mesh file, or an instance ``instance_exists`` knows."""
    from catpose.datasets.templates import template_spec

    tset = getattr(dataset, "_templates", None)
    if tset is None:
        return
    for category, entries in tset.entries.items():
        for entry in entries:
            instance = tset.instance_of(entry)
            if instance is not None:
                if not instance_exists(category, instance):
                    report.warn(
                        f"template {instance} of {category} does not exist; protocol=templates needs it: fix "
                        f"dataset.templates.{category}"
                    )
                continue
            try:
                path = Path(template_spec(category, entry)["path"])
            except CatposeError as e:
                report.problem(str(e))
                continue
            full = path if path.is_absolute() or tset.base_dir is None else tset.base_dir / path
            if not full.is_file():
                report.warn(
                    f"template mesh {full} of {category} does not exist; protocol=templates needs it: set "
                    "dataset.templates_root to the folder of the template meshes"
                )
