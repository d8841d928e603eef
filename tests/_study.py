"""The studies' and tools' scripts in their tests (a study's carry the ``experiment`` marker): each
script run once as a module namespace, its functions called directly (``runpy``: a study folder is
no package)."""

from __future__ import annotations

import runpy
from pathlib import Path
from types import SimpleNamespace

import pytest

REPO = Path(__file__).resolve().parents[1]


def run_study(path: str) -> dict:
    """The namespace of the study script at ``path`` (repository-relative, ``experiments/...``)."""
    return runpy.run_path(str(REPO / path))


def study_fixture(path: str):
    """A module-scoped fixture giving :func:`run_study` of ``path``, run once per test module."""

    @pytest.fixture(scope="module")
    def study_namespace() -> dict:
        return run_study(path)

    return study_namespace


def study_module(path: str):
    """A module-scoped fixture giving :func:`run_study` of ``path`` as attributes
    (``summary.write_tables(...)``, as if the script were an imported module)."""

    @pytest.fixture(scope="module")
    def study_namespace() -> SimpleNamespace:
        return SimpleNamespace(**run_study(path))

    return study_namespace
