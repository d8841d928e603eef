"""Ours' defaults live in one place: configs/method/ours.yaml (issue 40). The settings dataclasses
keep defaults so that ``Ours()`` works from Python, and this test fails when any of them differs
from the YAML, when a setting has no key, or when a key has no one-line comment."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest
import yaml

from catpose.methods.ours.settings import OptimiserSettings, RestingSettings, SelectionSettings

YAML = Path(__file__).resolve().parents[1] / "configs" / "method" / "ours.yaml"
GROUPS = {"optimiser": OptimiserSettings, "selection": SelectionSettings, "resting": RestingSettings}


@pytest.fixture(scope="module")
def config() -> dict:
    return yaml.safe_load(YAML.read_text())


@pytest.mark.parametrize("group", sorted(GROUPS))
def test_every_setting_has_a_key_with_the_dataclass_default(config, group):
    node = {k: v for k, v in config[group].items() if k != "_target_"}
    fields = {f.name: f.default for f in dataclasses.fields(GROUPS[group])}
    assert set(node) == set(fields), f"method.{group}: keys and {GROUPS[group].__name__} fields differ"
    for key, default in fields.items():
        assert node[key] == default, f"method.{group}.{key}: ours.yaml says {node[key]!r}, the dataclass {default!r}"


def test_at_most_25_keys(config):
    """Issue 58: a key stays only if a user or a study changes it; the rest are named constants of
    the stage that uses them (docs/choosing-defaults.md says where each was chosen)."""
    keys = [k for g in GROUPS for k in config[g] if k != "_target_"]
    assert len(keys) <= 25, keys


def test_one_comment_line_per_key_and_no_measurement_log():
    """Every key line carries its comment (meaning, unit, range); comment lines of their own are
    only the file's header (the history of each default is in docs/choosing-defaults.md)."""
    lines = YAML.read_text().splitlines()
    header = 0
    while header < len(lines) and lines[header].startswith("#"):
        header += 1
    body = lines[header:]
    assert not [ln for ln in body if ln.strip().startswith("#")], "comment lines below the header"
    keys = [ln for ln in body if re.match(r"^\s*[a-z_]+:\s*\S", ln) and not ln.strip().startswith(("_target_", "-"))]
    assert keys
    bare = [ln.strip() for ln in keys if "#" not in ln and not ln.strip().startswith("name:")]
    assert not bare, f"keys without a comment: {bare}"
