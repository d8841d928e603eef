"""Shared fixtures.

Real fixtures live in ``../shared/data`` beside the checkout (never copied into the project);
tests that need them take the ``shared_data`` fixture, which skips with a clear message when the
folder is absent. ``CATPOSE_SHARED_DATA`` overrides the location.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def shared_data() -> Path:
    from catpose.bench.run.config import shared_data_dir  # the one definition the commands use too

    path = shared_data_dir()
    if not path.is_dir():
        pytest.skip(f"real fixtures not found at {path} (set CATPOSE_SHARED_DATA to their folder)")
    return path


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture(scope="module")
def one_torch_thread():
    """One torch thread (the runner's ``threads=1``, what the gate's worker processes take): the
    module's solver tests are small, and extra threads only contend on a shared machine."""
    from catpose import extras

    if not extras.installed("torch"):  # the torch extra is absent: nothing uses its threads
        yield
        return
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture(scope="module")
def private_cache_dir(tmp_path_factory):
    """``CATPOSE_CACHE_DIR`` in a fresh folder for the module: dictionaries built by its tests,
    never read from or written to the user's cache."""
    mp = pytest.MonkeyPatch()
    mp.setenv("CATPOSE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    yield
    mp.undo()
