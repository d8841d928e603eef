"""Every config of every group composes and instantiates (a new file is covered without edits).

Method, dataset, protocol and choice configs are composed through the ``run`` config, exactly as
``bench run`` does, and built by the same builder. Datasets that need real data are built on
``../shared/data`` when it is present; without it, or for files not shipped there, they must stop
with a one-line error that names ``dataset.root``. Experiment files are composed as
``+experiment=<name>``. Hydra launcher presets compose with or without their plugin (a stand-in
for the plugin's base config when it is absent). Any other group's file with a ``_target_`` is
instantiated on its own; a fragment without one must be in a method's defaults list.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from catpose.errors import CatposeError

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
RUN_GROUPS = ("method", "dataset", "protocol", "choice")
NOT_HYDRA = {"regress", "split"}  # plain YAML read by `bench regress` / `bench suite`, not Hydra groups

#: dataset config -> folder under ../shared/data that holds a small copy of its layout
SHARED_ROOTS = {
    "modelnet40": "ModelNet40",
    "modelnet40_resampled": "modelnet40_normal_resampled",
    "modelnet40_aligned": "ModelNet40",
    "bop": "bop/tyol",
    "tyol": "bop/tyol",
    "ycbv": "bop/ycbv",
    "clutter": "bop/ycbv",
    "redwood": "redwood",
}


def _optional_modules() -> dict[str, str]:
    """Method config -> the optional module it needs (the registry's ``requires``; its absence must
    be a one-line error naming it)."""
    from catpose.methods.registry import registered

    return {name: spec.requires for name, spec in registered().items() if spec.requires}


OPTIONAL_MODULES = _optional_modules()


def _importable(module: str) -> bool:
    import importlib

    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


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


def _defaults_of(path: Path) -> set[tuple[str, str]]:
    """(group, name) of every config a file's defaults list pulls in: ``- /pipeline/correspondence@_here_``
    -> ("pipeline", "correspondence"); ``- /descriptor@descriptor: lps`` -> ("descriptor", "lps");
    a relative ``- teaser`` -> (the file's own group, "teaser"). Comments and other keys are not read."""
    from omegaconf import OmegaConf

    own = path.parent.relative_to(CONFIGS).as_posix()
    out = set()
    for item in OmegaConf.to_container(OmegaConf.load(path)).get("defaults", []):
        if isinstance(item, dict):
            ((key, value),) = item.items()
            group = key.split("@")[0].split(" ")[-1]  # "override /dataset" -> "/dataset"
            out.add((group.lstrip("/") if group.startswith("/") else f"{own}/{group}", str(value)))
        elif item != "_self_":
            ref = str(item).split("@")[0]
            out.add(tuple(ref.lstrip("/").rsplit("/", 1)) if ref.startswith("/") else (own, ref))
    return out


#: launcher preset -> (its plugin, the plugin's config the preset extends, that config's _target_)
LAUNCHERS = {
    "local_procs": (
        "hydra_joblib_launcher",
        "joblib",
        "hydra_plugins.hydra_joblib_launcher.joblib_launcher.JoblibLauncher",
    ),
    "slurm": (
        "hydra_submitit_launcher",
        "submitit_slurm",
        "hydra_plugins.hydra_submitit_launcher.submitit_launcher.SlurmLauncher",
    ),
    "ray_local": ("hydra_ray_launcher", "ray", "hydra_plugins.hydra_ray_launcher.ray_launcher.RayLauncher"),
}


def _check_launcher_preset(group: str, name: str, monkeypatch) -> None:
    """Compose ``hydra/launcher=<name>``: with its plugin when installed, else over a stand-in for the
    plugin's base config (its ``_target_`` only), so the preset's YAML, its base and its keys are
    checked without the cluster extra; only running a sweep needs the plugin (tests/test_scaleout.py)."""
    import copy
    import importlib.util

    from hydra import compose, initialize_config_module
    from hydra.core.config_store import ConfigStore

    assert group == "hydra/launcher" and name in LAUNCHERS, f"configs/{group}/{name}.yaml: add it to LAUNCHERS"
    plugin, base, target = LAUNCHERS[name]
    assert _defaults_of(CONFIGS / group / f"{name}.yaml") == {("hydra/launcher", base)}
    try:  # without any launcher plugin even the hydra_plugins namespace is absent
        installed = importlib.util.find_spec(f"hydra_plugins.{plugin}") is not None
    except ModuleNotFoundError:
        installed = False
    if not installed:
        store = ConfigStore.instance()
        monkeypatch.setattr(store, "repo", copy.deepcopy(store.repo))  # the stand-in leaves with the test
        store.store(group="hydra/launcher", name=base, node={"_target_": target}, provider="test")
    with initialize_config_module("catpose.configs", version_base="1.3"):
        launcher = compose("run", overrides=[f"hydra/launcher={name}"], return_hydra_config=True).hydra.launcher
    assert launcher._target_ == target
    if name == "slurm":
        assert launcher.timeout_min > 0 and launcher.cpus_per_task >= 1 and launcher.mem_gb > 0
        assert "partition" in launcher and launcher.array_parallelism >= 1
    elif name == "local_procs":
        assert launcher.n_jobs == 2 and launcher.prefer == "processes"
    else:
        assert launcher.ray.init.num_cpus == 2 and launcher.ray.remote.num_cpus == 1


@pytest.mark.parametrize("group,name", _all_configs(), ids=lambda v: str(v))
def test_config_composes_and_builds(group: str, name: str, tmp_path: Path, monkeypatch) -> None:
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
        if optional and not _importable(optional):  # refused in one line naming what to install
            with pytest.raises(CatposeError, match=re.escape(optional)):
                build_from_config(cfg[group], group)
            return
        built_name, obj = build_from_config(cfg[group], group)
        assert built_name == name  # a config's name is its file's (run directories are named by it)
        if group == "method":
            assert callable(getattr(obj, "register", None))
        elif group == "protocol":
            assert callable(getattr(obj, "sample_ids", None))
        elif group == "choice":  # the method side's template choice: facts after a registration, then a rule
            assert callable(getattr(obj, "estimate_facts", None)) and obj.rule.rule == name
        return
    if top == "experiment":
        cfg = _compose([f"+experiment={name}"])
        assert cfg.method and cfg.dataset
        return
    if top == "row":  # a table row of configs/experiment: composes on its own and builds its method
        cfg = _compose([f"+row={name}"])
        optional = OPTIONAL_MODULES.get(str(cfg.method.name))
        if optional and not _importable(optional):
            with pytest.raises(CatposeError, match=re.escape(optional)):
                build_from_config(cfg.method, "method")
            return
        assert build_from_config(cfg.method, "method")[0] == cfg.method.name
        return
    if top == "category_templates":  # templates and test-view exclusions of the mn40r experiments
        cfg = _compose([f"+category_templates={name}", "dataset=modelnet40_resampled", "protocol=templates"])
        (category,) = [c for c in ("airplane", "chair") if name.startswith(f"mn40r_{c}")]
        assert set(cfg.dataset.templates[category]) <= set(cfg.protocol.exclude_instances)
        return
    if top == "hydra":  # a launcher preset composes whether or not its plugin is installed
        _check_launcher_preset(group, name, monkeypatch)
        return
    from hydra.utils import instantiate

    node = OmegaConf.load(CONFIGS / group / f"{name}.yaml")
    if "_target_" in node:
        node = {k: v for k, v in OmegaConf.to_container(node, resolve=False).items() if k not in ("name", "defaults")}
        assert instantiate(node, _convert_="all") is not None
    else:
        # a fragment merged into other configs (e.g. a shared pipeline block): some method config
        # names it in its defaults list, and that method, composed, carries every key of it
        users = [p.stem for p in sorted((CONFIGS / "method").glob("*.yaml")) if (group, name) in _defaults_of(p)]
        assert users, f"configs/{group}/{name}.yaml is in no method config's defaults list"
        keys = [k for k in OmegaConf.load(CONFIGS / group / f"{name}.yaml") if k != "defaults"]
        for user in users:
            method = _compose([f"method={user}"]).method
            assert all(k in method for k in keys), (user, [k for k in keys if k not in method])
