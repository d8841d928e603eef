"""Every registered method (catpose.methods.registry), built from its config in configs/method,
registers a tiny problem with a known transform: a rendered partial view of a procedural chair
against its own complete model. The methods and their quick options come from the registry, so a
new method is tested without an edit here."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import catpose

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import chair_template, partial_problem, rotation_error_deg  # noqa: E402

from catpose.methods.registry import registered  # noqa: E402

SPECS = registered()

pytestmark = pytest.mark.usefixtures("one_torch_thread", "private_cache_dir")


@pytest.fixture(scope="module")
def problem():
    return partial_problem(chair_template(), 3)


def test_every_method_config_is_registered_and_every_method_has_a_config(repo_root):
    names = {p.stem for p in (repo_root / "configs" / "method").glob("*.yaml")}
    assert names == set(SPECS), f"configs without a registered class, or the reverse: {sorted(names ^ set(SPECS))}"


@pytest.mark.parametrize("name", sorted(SPECS))
def test_method_recovers_a_known_transform(problem, name: str):
    spec = SPECS[name]
    if spec.requires:
        pytest.importorskip(spec.requires, reason=f"{spec.requires} (an optional extra) is not installed")
    p, T_gt = problem
    method = catpose.build_method(name, **spec.smoke_options)
    assert isinstance(method, spec.cls)
    r = method.register(p)
    T = r.T_template_camera
    assert rotation_error_deg(T[:3, :3], T_gt[:3, :3]) < 5.0
    assert np.linalg.norm(T[:3, 3] - T_gt[:3, 3]) < 0.1
    assert np.isfinite(r.score)


@pytest.mark.parametrize("name", sorted(SPECS))
def test_the_api_builds_the_method_bench_run_builds(name: str):
    """The API's builder (PyYAML, no Hydra) and the bench's (Hydra) give the same object, option for option."""
    from catpose.api.method_cache import build_method
    from catpose.bench.run.config import compose_and_build

    if SPECS[name].requires:
        pytest.importorskip(SPECS[name].requires, reason=f"{SPECS[name].requires} (an optional extra) is not installed")
    _, ((_, bench),) = compose_and_build([f"method={name}"], ("method",))
    api = build_method(name)
    assert type(api) is type(bench)
    assert _state(api) == _state(bench)


def _state(obj) -> object:
    """An object's configuration as plain values (its attributes, nested objects' too; caches left out)."""
    if isinstance(obj, (list, tuple)):
        return [_state(v) for v in obj]
    if isinstance(obj, dict):
        return {k: _state(v) for k, v in obj.items()}
    if hasattr(obj, "__dict__") and not isinstance(obj, type):
        return (
            type(obj).__name__,
            {k: _state(v) for k, v in vars(obj).items() if "cache" not in k and not k.startswith("_")},
        )
    return obj


def test_labels_the_real_suite_and_the_api_read_the_registry():
    """A registered method is in the report's labels, ``bench suite``'s rows and the API's up search
    without any of those files naming it (``gicp`` was added as its module and its config only)."""
    from catpose.bench.real.suite_sets import METHODS
    from catpose.bench.report.labels import display_name
    from catpose.methods.registry import needs_up

    for name, spec in SPECS.items():
        assert display_name(name) == spec.display_name
        assert {row.label for row in spec.suite_rows()} <= set(METHODS)
        assert all(METHODS[row.label].method == name for row in spec.suite_rows())
    assert display_name("gicp") == "GICP" and METHODS["gicp"].overrides == ()
    assert list(METHODS)[:3] == ["ours", "ours-visibility", "icp"]  # the rows' order: their ranks
    build = catpose.build_method
    assert needs_up(build("ours")) and needs_up(build("fgr", features="lps"))
    assert not needs_up(build("icp")) and not needs_up(build("fgr"))
