"""The paper's method (methods/ours.py) on rendered partial views with known poses."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import chair_template, partial_problem, rotation_error_deg  # noqa: E402

from catpose.errors import ConfigError  # noqa: E402
from catpose.methods.ours import Ours, kabsch  # noqa: E402

FAST = dict(steps_pose=100, steps_joint=100, lr=2e-2)


@pytest.fixture(scope="module")
def template():
    return chair_template()


@pytest.fixture(scope="module")
def problems(template):
    return [partial_problem(template, s) for s in range(10)]


@pytest.fixture(scope="module", autouse=True)
def _cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("CATPOSE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    yield
    mp.undo()


def test_partial_view_to_own_model_is_accurate(problems):
    method = Ours()  # the defaults of configs/method/ours.yaml
    errs = [rotation_error_deg(method.register(p).T_target_source[:3, :3], T[:3, :3]) for p, T in problems]
    assert np.median(errs) < 2.0, errs


def test_same_problem_gives_same_pose_and_json_extras(problems):
    p, _ = problems[0]
    a, b = Ours(**FAST).register(p), Ours(**FAST).register(p)
    np.testing.assert_array_equal(a.T_target_source, b.T_target_source)
    assert a.score == b.score and np.isfinite(a.score)
    extras = json.loads(json.dumps(a.extras))
    assert len(extras["losses"]) == 18 and 0 <= extras["template_index"] < 18
    assert set(extras["timings"]) == {"dictionary", "descriptors", "affinity", "initial_pose", "optimization",
                                      "selection", "refinement"}


@pytest.mark.parametrize("kw", [dict(optimize="none"), dict(optimize="pose"), dict(descriptor="pfh"),
                                dict(selection="chamfer", gravity_max_deg=20.0, chamfer_weight=0.1, chamfer_points=64),
                                dict(refine=False), dict(stage2_top_k=4), dict(selection="loss", gravity_max_deg=None)])
def test_ablations_run_and_return_rigid_poses(problems, kw):
    from catpose.types import validate_pose

    p, T_gt = problems[1]
    r = Ours(**{**FAST, **kw}).register(p)
    validate_pose("estimate", r.T_target_source)
    assert np.isfinite(r.score)


def test_optimisation_lowers_the_loss(problems):
    p, _ = problems[2]
    svd = Ours(optimize="none").register(p)
    opt = Ours(optimize="pose", refine=False, **FAST).register(p)
    # same candidates, same affinities: stage 1 can only lower each candidate's loss
    assert np.all(np.array(opt.extras["losses"]) <= np.array(svd.extras["losses"]) + 1e-6)


def test_kabsch_recovers_a_transform_and_fixes_reflections():
    rng = np.random.default_rng(0)
    from catpose.geometry import random_rotation

    P = rng.normal(size=(2, 20, 3))
    R = random_rotation(rng)
    Q = P @ R.T + np.array([1.0, 2.0, 3.0])
    T = kabsch(P, Q)
    np.testing.assert_allclose(T[:, :3, :3], np.broadcast_to(R, (2, 3, 3)), atol=1e-9)
    Tm = kabsch(P, Q * np.array([1.0, 1.0, -1.0]))        # mirrored target: still a rotation
    np.testing.assert_allclose(np.linalg.det(Tm[:, :3, :3]), 1.0)


def test_bad_options_raise_config_errors():
    with pytest.raises(ConfigError, match="descriptor"):
        Ours(descriptor="fpfh")
    with pytest.raises(ConfigError, match="optimize"):
        Ours(optimize="lbfgs")


def test_config_composes_and_instantiates(repo_root):
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    cfg = OmegaConf.load(repo_root / "configs" / "method" / "ours.yaml")
    d = OmegaConf.to_container(OmegaConf.merge({"seed": 0}, {"m": cfg}), resolve=True)["m"]
    assert d.pop("name") == "ours"
    method = instantiate(d, _convert_="all")
    assert isinstance(method, Ours)


def test_analytic_gradients_match_autograd():
    import torch

    from catpose.methods.optim import BatchedProblem, loss_autograd

    g = torch.Generator().manual_seed(0)
    m, n = 3, 6
    kw = dict(dtype=torch.float64)
    A = torch.softmax(torch.randn(m, n, 2 * n, generator=g, **kw), 2)
    prob = BatchedProblem(torch.randn(n, 3, generator=g, **kw), torch.randn(m, 2 * n, 3, generator=g, **kw), A,
                          torch.randn(10, 3, generator=g, **kw), torch.randn(15, 3, generator=g, **kw), 0.5)
    r6 = torch.randn(m, 6, generator=g, **kw).requires_grad_(True)
    t = torch.randn(m, 3, generator=g, **kw).requires_grad_(True)
    L = torch.randn(m, n, 2 * n, generator=g, **kw).requires_grad_(True)
    loss_autograd(prob, r6, t, L).sum().backward()
    loss, g6, gt, gL = prob.loss_and_grads(r6.detach(), t.detach(), L.detach())
    np.testing.assert_allclose(loss.numpy(), loss_autograd(prob, r6, t, L).detach().numpy(), atol=1e-10)
    for a, b in ((g6, r6.grad), (gt, t.grad), (gL, L.grad)):
        np.testing.assert_allclose(a.numpy(), b.numpy(), atol=1e-9)


@pytest.mark.slow
@pytest.mark.data
def test_modelnet40_airplanes_own_model(shared_data):
    """Real ModelNet40 airplanes: partial views against their own complete models."""
    import glob

    from catpose.datasets.meshio import mesh_to_template, read_mesh

    files = sorted(glob.glob(str(shared_data / "ModelNet40" / "airplane" / "*" / "*.off")))[:3]
    if not files:
        pytest.skip("no ModelNet40 airplanes in the shared data")
    errs = []
    method = Ours()
    for f in files:
        v, tri = read_mesh(f)
        t = mesh_to_template(v, tri, Path(f).stem, "airplane", n_points=2048)
        for s in range(3):
            p, T = partial_problem(t, s)
            errs.append(rotation_error_deg(method.register(p).T_target_source[:3, :3], T[:3, :3]))
    assert np.median(errs) < 2.0, errs


@pytest.mark.slow
def test_bench_perf_prints_a_table(capsys):
    from catpose.bench.perf import main

    assert main(["--n", "2", "--methods", "ours", "--categories", "chair"]) == 0
    out = capsys.readouterr().out
    assert "| ours" in out and "optimization" in out
