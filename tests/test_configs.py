"""Every config of every group composes and instantiates (a new file is covered without edits).

Method, dataset and protocol configs are composed through the ``run`` config, exactly as
``bench run`` does, and built by the same builder. Datasets that need real data are built on
``../shared/data`` when it is present; without it, or for files not shipped there, they must stop
with a one-line error that names ``dataset.root``. Experiment files are composed as
``+experiment=<name>``. Any other group's file with a ``_target_`` is instantiated on its own.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from catpose.errors import CatposeError

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
RUN_GROUPS = ("method", "dataset", "protocol")
NOT_HYDRA = {"regress"}  # plain YAML read by `bench regress`, not a Hydra group

#: dataset config -> folder under ../shared/data that holds a small copy of its layout
SHARED_ROOTS = {"modelnet40": "ModelNet40", "modelnet40_resampled": "modelnet40_normal_resampled",
                "modelnet40_aligned": "ModelNet40", "bop": "bop/tyol", "tyol": "bop/tyol", "ycbv": "bop/ycbv",
                "redwood": "redwood"}
#: method config -> the optional module it needs (its absence must be a one-line error naming it)
OPTIONAL_MODULES = {"teaserpp": "teaserpp_python"}


def _all_configs() -> list[tuple[str, str]]:
    out = []
    for group_dir in sorted(p for p in CONFIGS.rglob("*") if p.is_dir() and p.name != "__pycache__"):
        group = group_dir.relative_to(CONFIGS).as_posix()
        if group.split("/")[0] in NOT_HYDRA:
            continue
        out += [(group, f.stem) for f in sorted(group_dir.glob("*.yaml"))]
    return out


def _compose(overrides: list[str]):
    from hydra import compose, initialize_config_module

    with initialize_config_module("catpose.configs", version_base=None):
        return compose("run", overrides=overrides)


@pytest.mark.parametrize("group,name", _all_configs(), ids=lambda v: str(v))
def test_config_composes_and_builds(group: str, name: str, tmp_path: Path) -> None:
    from omegaconf import OmegaConf

    from catpose.bench.run.build import build_from_config

    top = group.split("/")[0]
    if group in RUN_GROUPS:
        overrides = [f"{group}={name}"]
        shared = CONFIGS.parents[1] / "shared" / "data"
        cfg = _compose(overrides)
        needs_root = group == "dataset" and OmegaConf.is_missing(cfg.dataset, "root")
        if needs_root and name in SHARED_ROOTS and (shared / SHARED_ROOTS[name]).is_dir():
            overrides.append(f"dataset.root={shared / SHARED_ROOTS[name]}")
            cfg = _compose(overrides)
        if needs_root and not any(o.startswith("dataset.root=") for o in overrides):
            with pytest.raises(CatposeError, match="dataset.root"):
                build_from_config(cfg[group], group)
            return
        optional = OPTIONAL_MODULES.get(name) if group == "method" else None
        if optional:
            import importlib.util

            if importlib.util.find_spec(optional) is None:
                with pytest.raises(CatposeError, match=optional):
                    build_from_config(cfg[group], group)
                return
        built_name, obj = build_from_config(cfg[group], group)
        assert built_name == name or group == "dataset"
        if group == "method":
            assert callable(getattr(obj, "register", None))
        elif group == "protocol":
            assert callable(getattr(obj, "sample_ids", None))
        return
    if top == "experiment":
        cfg = _compose([f"+experiment={name}"])
        assert cfg.method and cfg.dataset
        return
    if top == "row":  # a table row of configs/experiment: composes on its own and builds its method
        cfg = _compose([f"+row={name}"])
        assert build_from_config(cfg.method, "method")[0] == cfg.method.name
        return
    if top == "hydra":
        pytest.skip("Hydra launcher presets are composed by the scale-out tests")
    from hydra.utils import instantiate

    node = OmegaConf.load(CONFIGS / group / f"{name}.yaml")
    if "_target_" in node:
        node = {k: v for k, v in OmegaConf.to_container(node, resolve=False).items() if k not in ("name", "defaults")}
        assert instantiate(node, _convert_="all") is not None
    else:
        # a fragment merged into other configs (e.g. a shared pipeline block): it must be valid YAML
        # that some method config includes
        users = [p for p in (CONFIGS / "method").glob("*.yaml") if f"{group}" in p.read_text()]
        assert users, f"configs/{group}/{name}.yaml is used by no method config"
