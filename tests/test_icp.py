"""ICP from 20 starts: the SO(3) partition and recovery of a known pose."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from catpose.bench.scoring.metrics import rotation_error_deg, translation_error
from catpose.errors import ConfigError
from catpose.geometry import quat_to_R
from catpose.methods.icp import ICP, icp_starts, so3_partition_centres
from catpose.types import RegistrationProblem

sys.path.insert(0, str(Path(__file__).resolve().parent))
from toy_dataset import ToyDataset  # noqa: E402


def test_partition_centres_cover_so3():
    C = so3_partition_centres(20)
    assert C.shape == (20, 3, 3)
    assert np.allclose(np.einsum("kij,kil->kjl", C, C), np.eye(3), atol=1e-9)
    q = np.random.default_rng(7).normal(size=(3000, 4))
    R = quat_to_R(q)
    nearest = np.array([min(rotation_error_deg(r, c) for c in C) for r in R[:500]])
    # 20 equal balls cover SO(3) only from a radius of about 57 degrees; k-means reaches ~75
    assert nearest.max() < 80.0 and nearest.mean() < 55.0
    pairwise = [rotation_error_deg(C[i], C[j]) for i in range(20) for j in range(i + 1, 20)]
    assert min(pairwise) > 60.0
    assert np.array_equal(so3_partition_centres.__wrapped__(20), C)  # deterministic


def test_stored_starts_are_the_partition_centres():
    """The default 20 starts are the k-means' centres (to the last bits the CPU kernel moves); any
    other count is computed."""
    assert np.allclose(icp_starts(20), so3_partition_centres(20), atol=1e-12, rtol=0.0)
    assert np.array_equal(icp_starts(12), so3_partition_centres(12))


ICP_SCRIPT = r"""
import hashlib
import numpy as np
from catpose.bench.protocols.absolute import GtModel
from catpose.datasets.synthetic import SyntheticDataset
from catpose.datasets.views import ViewOptions
from catpose.methods.icp import ICP
ds = SyntheticDataset(seed=3, categories=["mug", "chair", "bottle"], instances_per_category=1, views_per_instance=2,
                      view=ViewOptions(max_points=500), template_points=500)
proto, icp, h = GtModel(), ICP(), hashlib.sha1()
for sid in proto.sample_ids(ds):
    h.update(np.asarray(icp.register(proto.load(ds, sid).problem).T_template_camera, dtype=np.float64).tobytes())
print(h.hexdigest())
"""


@pytest.mark.slow  # a process per code path: make test-slow
def test_icp_answers_are_the_same_bits_under_every_fma_code_path():
    """ICP's answers do not depend on the CPU's kernels (OpenBLAS SkylakeX or Haswell, NumPy with or
    without AVX-512): its starts are stored, not computed. OpenBLAS's Sandybridge kernel (CPUs
    without FMA) still rounds the starts' translation ``R @ c`` differently and is left out."""
    from _code_paths import last_line

    from catpose.bench.run.environment import numeric_variants

    variants = {k: v for k, v in numeric_variants().items() if k not in ("Sandybridge", "torch-default")}
    if len(variants) < 2:
        pytest.skip("needs an x86-64 CPU with AVX2 to run another code path")
    digests = {name: last_line(ICP_SCRIPT, env) for name, env in variants.items()}
    assert len(set(digests.values())) == 1, digests


def test_icp_recovers_the_pose_of_a_view_against_its_own_model():
    ds = ToyDataset(seed=3, num_views=3)
    method = ICP()
    for obs_id in ds.observation_ids():
        obs = ds.observation(obs_id)
        problem = RegistrationProblem(
            obs_id, obs.category, obs.points_camera, obs.normals_camera, obs.ground_normal_camera, ds.template
        )
        res = method.register(problem)
        T = res.T_template_camera
        assert rotation_error_deg(T[:3, :3], obs.T_object_camera[:3, :3]) < 2.0
        assert translation_error(T[:3, 3], obs.T_object_camera[:3, 3]) < 0.05
        assert res.extras["fitness"] > 0.9 and len(res.extras["starts_fitness"]) == 20


def test_bad_options_are_config_errors():
    with pytest.raises(ConfigError, match="num_starts"):
        ICP(num_starts=0)
    with pytest.raises(ConfigError):
        ICP(max_correspondence_distances=[-1.0])
