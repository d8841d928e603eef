"""The descriptor strategies (methods/descriptors.py: LPS, PFH) and the dictionary layout."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from catpose.errors import ConfigError
from catpose.methods import lps
from catpose.methods.descriptors import LPS, PFH, Descriptor
from catpose.methods.dictionary import DictionaryLayout, viewpoint_layout

DESCRIPTORS = [LPS(), PFH()]


def _cloud(seed: int = 0, n: int = 1500) -> tuple[np.ndarray, np.ndarray]:
    """An ellipsoid with a bump: points (n, 3) and unit normals, object-normalised size."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = 1.0 + 0.3 * np.exp(-np.sum((d - [0.6, 0.0, 0.8]) ** 2, axis=1) / 0.1)
    p = d * r[:, None] * np.array([0.9, 0.6, 0.5])
    nrm = p / np.array([0.9, 0.6, 0.5]) ** 2  # ellipsoid normal (approximate on the bump)
    return p, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


@pytest.mark.parametrize("desc", DESCRIPTORS, ids=["lps", "pfh"])
def test_batched_affinity_equals_pairwise(desc: Descriptor) -> None:
    p, n = _cloud()
    up = np.array([0.0, 0.0, 1.0])
    a = desc.keypoint_features(p, n, 16, up)
    assert len(a.indices) == 16 and a.keypoints.shape == (16, 3)
    sets = [desc.keypoint_features(*_cloud(s), 24, up).features for s in (1, 2, 3)]
    batched = desc.batched_affinity(a.features, desc.stack(sets))
    assert batched.shape == (3, 16, 24)
    for i, b in enumerate(sets):
        pair = desc.affinity(a.features, b)
        # the batched LPS grid product keeps the grids' float32; the values are the same
        np.testing.assert_array_equal(batched[i], pair.astype(batched.dtype))


def test_fscore_voxel_equals_the_dense_grid_formula() -> None:
    """The sparse product of fscore_voxel is the same number as the dense counts @ dilated^T."""
    p, n = _cloud()
    d = LPS()
    a = d.keypoint_features(p, n, 16, np.array([0.0, 0.0, 1.0])).features
    b = d.keypoint_features(*_cloud(1), 32, np.array([0.0, 0.0, 1.0])).features
    prec = (a.counts @ b.dilated.T) / np.maximum(a.n[:, None], 1)
    rec = (a.dilated @ b.counts.T) / np.maximum(b.n[None], 1)
    s = prec + rec
    dense = np.where(s > 0, 2 * prec * rec / np.maximum(s, 1e-12), 0.0)
    np.testing.assert_array_equal(lps.fscore_voxel(a, b), dense.astype(np.float64))
    assert dense.max() > 0.5


def test_pfh_affinity_is_invariant_to_a_rigid_motion() -> None:
    """Rotating the cloud leaves the affinities unchanged (PFH pair features rotate with the cloud;
    LPS: tests/test_lps.py)."""
    desc = PFH()
    p, n = _cloud()
    up = np.array([0.0, 0.0, 1.0])
    R = Rotation.random(random_state=np.random.default_rng(9)).as_matrix()
    a = desc.keypoint_features(p, n, 16, up)
    moved = a.points @ R.T + 0.5  # the same downsampled cloud, moved
    b = desc.describe(moved, a.normals @ R.T, a.indices, R @ up, cKDTree(moved))
    np.testing.assert_allclose(desc.affinity(a.features, b), desc.affinity(a.features, a.features), atol=1e-6)


def test_cache_keys_name_every_parameter() -> None:
    assert LPS().cache_key() == LPS().cache_key()
    assert LPS(tau=0.02).cache_key() != LPS().cache_key()
    assert PFH(eps=0.02).cache_key() != PFH().cache_key()
    assert LPS().cache_key()[0] == "lps" and PFH().cache_key()[0] == "pfh"
    assert ("voxel_size", 0.025) in LPS().cache_key()


@pytest.mark.parametrize(
    "make,match",
    [
        (lambda: LPS(tau="abc"), "method.descriptor.tau='abc' must be a positive number"),
        (lambda: LPS(max_points=0), "method.descriptor.max_points=0 must be a positive integer"),
        (lambda: PFH(eps=0), "method.descriptor.eps=0 must be a positive number"),
        (lambda: PFH(voxel_size=-1), "method.descriptor.voxel_size=-1 must be a number >= 0"),
        (lambda: DictionaryLayout(num_views=17), "method.dictionary.num_views=17 is not a multiple of the 3"),
        (lambda: DictionaryLayout(num_keypoints=2), "method.dictionary.num_keypoints=2 must be an integer >= 3"),
    ],
)
def test_bad_options_raise_one_line_errors_naming_the_key(make, match: str) -> None:
    with pytest.raises(ConfigError, match=match.replace("(", r"\(").replace(".", r"\.")) as info:
        make()
    assert "\n" not in str(info.value)


def test_dictionary_layout_is_the_viewpoint_layout() -> None:
    layout = DictionaryLayout(elevations_deg=[0, 45], num_views=12)
    assert layout.elevations_deg == (0.0, 45.0)
    np.testing.assert_array_equal(layout.viewpoints(), viewpoint_layout(12, (0.0, 45.0), 3.0))


@pytest.mark.parametrize("group,cls", [("descriptor", Descriptor), ("dictionary", DictionaryLayout)])
def test_every_shared_group_config_instantiates_into_ours_and_the_baselines(repo_root, group: str, cls: type) -> None:
    """Each file of configs/descriptor and configs/dictionary, selected for ours and for a
    correspondence baseline, reaches the method as the same typed object (one source, no mirror)."""
    from hydra import compose, initialize_config_module
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    names = sorted(p.stem for p in (repo_root / "configs" / group).glob("*.yaml"))
    assert names
    for name in names:
        built = []
        for method in ("ours", "teaser"):
            with initialize_config_module("catpose.configs", version_base=None):
                cfg = compose("run", overrides=[f"method={method}", f"{group}@method.{group}={name}"])
            d = OmegaConf.to_container(cfg.method, resolve=True)
            d.pop("name")
            obj = instantiate(d, _convert_="all")
            part = obj.descriptor if group == "descriptor" else obj.layout
            assert isinstance(part, cls)
            built.append(part.cache_key() if group == "descriptor" else part)
        assert built[0] == built[1]
