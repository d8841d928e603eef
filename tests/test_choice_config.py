"""The ``choice`` config group (configs/choice): every weight and angle a key, its value the one
default, the old ``protocol.choice`` keys refused in one line, and run directories written before
the group still building their protocol and choice."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from catpose.errors import ConfigError

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def _compose(overrides: list[str]):
    from catpose.bench.run.config import compose

    return compose(overrides)


def test_every_key_of_the_choice_is_in_the_base_file_with_its_python_default_and_a_comment():
    from catpose.methods.cross_check import CrossCheck
    from catpose.methods.template_choice import TemplateChoice

    path = CONFIGS / "choice" / "score.yaml"
    node = OmegaConf.to_container(OmegaConf.load(path))
    params = {k: p.default for k, p in inspect.signature(TemplateChoice).parameters.items()}
    keys = {k for k in node if k not in ("name", "_target_")}
    assert keys == set(params), "configs/choice/score.yaml and TemplateChoice take the same keys"
    check = {k: p.default for k, p in inspect.signature(CrossCheck).parameters.items()}
    assert {k: v for k, v in node["cross_check"].items() if k != "_target_"} == check, "choice.cross_check"
    for key in keys - {"rule", "cross_check"}:  # one default: the YAML's value is the constructor's
        default = list(params[key]) if isinstance(params[key], tuple) else params[key]
        assert node[key] == default, f"choice.{key}: YAML {node[key]!r}, Python {default!r}"
    for line in path.read_text().splitlines():  # one comment line per key, with its unit or range
        key = line.split(":", 1)[0]
        if key in keys:
            assert "#" in line and re.search(r"\((.*)\)", line.split("#", 1)[1]), line


def test_the_default_rule_is_the_same_for_bench_run_and_python():
    from catpose.methods.choice_rules import DEFAULT_RULE, ChoiceRule
    from catpose.methods.template_choice import TemplateChoice

    run_defaults = OmegaConf.load(CONFIGS / "run.yaml").defaults
    assert {"choice": DEFAULT_RULE} in [OmegaConf.to_container(d) for d in run_defaults if not isinstance(d, str)]
    assert TemplateChoice().rule.rule == ChoiceRule().rule == DEFAULT_RULE == "fused"
    assert _compose(["protocol=templates"]).choice.rule == DEFAULT_RULE


def test_each_rule_file_sets_its_rule_only():
    from catpose.methods.choice_rules import RULES

    assert sorted(p.stem for p in (CONFIGS / "choice").glob("*.yaml")) == sorted(RULES)
    for rule in RULES:
        if rule == "score":
            continue
        node = OmegaConf.to_container(OmegaConf.load(CONFIGS / "choice" / f"{rule}.yaml"))
        assert node == {"defaults": ["score", "_self_"], "name": rule, "rule": rule}
        cfg = _compose(["protocol=templates", f"choice={rule}"])
        assert cfg.choice.rule == rule and cfg.choice.cross_weight == 0.25


def test_the_builder_hands_the_choice_to_the_runner_and_its_rule_to_the_protocol():
    from catpose.bench.run.build import build_choice, build_protocol
    from catpose.methods.choice_rules import ChoiceRule

    cfg = _compose(["protocol=templates", "choice=fused", "choice.fused_top_weight=0.1", "choice.turns_deg=[180]"])
    chooser = build_choice(cfg)
    assert chooser.rule == ChoiceRule(rule="fused", fused_top_weight=0.1) and chooser.turns_deg == (180.0,)
    assert build_protocol(cfg).choice == chooser.rule
    relative = build_protocol(_compose(["protocol=relative", "choice=density"]))
    assert relative._views.choice == ChoiceRule(rule="density")
    gt = _compose(["protocol=gt_model", "choice=fused"])
    assert build_choice(gt) is None and not hasattr(build_protocol(gt), "choice")
    with pytest.raises(ConfigError, match=r"choice.turns_deg=.*must be a list of degrees"):
        build_choice(_compose(["protocol=templates", "choice.turns_deg=abc"]))
    with pytest.raises(ConfigError, match="choice.cross_weight='x' is not a float"):
        build_choice(_compose(["protocol=templates", "choice.cross_weight=x"]))


@pytest.mark.parametrize(
    "override,fix",
    [
        ("protocol.choice=fused", "unknown key 'protocol.choice'"),
        ("protocol.turns=[180]", "unknown key 'protocol.turns'"),
        ("choice=fuse", "unknown choice 'fuse'"),
    ],
)
def test_the_old_protocol_keys_and_an_unknown_rule_are_refused_in_one_line(override, fix):
    with pytest.raises(ConfigError, match=re.escape(fix)):
        _compose(["protocol=templates", override])


def test_a_templates_config_without_the_choice_group_is_refused_in_one_line():
    from catpose.bench.run.build import build_choice, build_protocol

    old = {"protocol": {"name": "templates", "_target_": "catpose.bench.protocols.Templates", "choice": "score"}}
    for build in (build_protocol, build_choice):
        with pytest.raises(ConfigError, match=r"the config has no choice; set choice=<name>"):
            build(old)


def test_the_choice_is_part_of_a_templates_runs_identity():
    from catpose.bench.run.rundir import run_dir_for

    def digest(overrides):
        return run_dir_for(_compose(overrides)).name.rsplit("-", 1)[1]

    assert digest(["protocol=gt_model"]) == digest(["protocol=gt_model", "choice.cross_weight=0.3"])
    assert digest(["protocol=templates"]) != digest(["protocol=templates", "choice.cross_weight=0.3"])
    assert digest(["protocol=templates", "choice=cross"]) != digest(["protocol=templates", "choice=fused"])
    assert digest(["protocol=relative"]) != digest(["protocol=relative", "choice=density"])
