"""``catpose.register`` is ``bench run``: every instance of the shared YCB-Video frames, and of a BOP
scene rendered here, through both gives the same ``T_template_camera`` (issue 41); on generated
frames (the synthetic set, no shared data) the API's method, built without Hydra, is the bench's
pose for pose, and for the methods that read no depth image and draw no random numbers, so is the
whole API path from the points.

The bench side is what ``bench run method=ours dataset=ycbv`` does per sample (the dataset and
protocol built from the configs, the sample loaded by the protocol, the method seeded by the
sample id and called); the API side is what a user does with the frame and the model
(the loader's depth frame and normalised model, :func:`api_inputs`, then ``catpose.register``). Both
go through :func:`catpose.datasets.frame_view.frame_view`; the estimates must agree to 1e-6 degrees
(they are the same bits).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import catpose

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_loaders_bop import bop_root  # noqa: E402, F401 (a fixture: a BOP scene rendered here)

pytestmark = pytest.mark.usefixtures("private_cache_dir", "one_torch_thread")


def rotation_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """The angle between two rotations, exact near 0 (``2 asin(|R_a - R_b|_F / sqrt 8)``)."""
    return float(np.degrees(2.0 * np.arcsin(min(1.0, np.linalg.norm(R_a - R_b) / np.sqrt(8.0)))))


def api_inputs(ds, sample_id: str, obj: int) -> tuple:
    """What a user gives ``catpose.Registrar`` for one BOP instance (as
    ``examples/register_bop_frame.py`` does): the loader's depth frame (raw depth, ``cam_K``, mask,
    ``depth_scale`` to mm), the model as the loader normalises it, the config's frame settings."""
    from catpose.api.inputs import NormalisedTemplate

    template = NormalisedTemplate(ds.instance_model(sample_id.split("/")[0], f"obj_{obj:06d}"), *ds.normalisation(obj))
    settings = ds.frame_settings
    options = {"max_points": settings.max_points, "plane_distance": settings.plane_distance}
    return ds.instance_frame(sample_id).frame, template, options


@pytest.mark.data
@pytest.mark.slow
def test_register_a_depth_frame_equals_bench_run_on_every_shared_ycbv_instance(shared_data):
    from catpose.bench.run.config import compose_and_build
    from catpose.bench.run.sample_run import seed_everything
    from catpose.geometry import stable_seed

    root = shared_data / "bop" / "ycbv"
    _, ((_, ds), (_, protocol), (_, method)) = compose_and_build(
        ["dataset=ycbv", f"dataset.root={root}", "method=ours", "seed=0"], ("dataset", "protocol", "method")
    )
    ids = protocol.sample_ids(ds)
    assert len(ids) == 38
    registrars: dict[int, catpose.Registrar] = {}
    worst = 0.0
    for sample_id in ids:
        sample = protocol.load(ds, sample_id)
        seed_everything(stable_seed(0, sample_id))
        bench = method.register(sample.problem)

        obj = int(sample.info["obj_id"])
        frame, template, options = api_inputs(ds, sample_id, obj)
        if obj not in registrars:
            registrars[obj] = catpose.Registrar(template, "ours")
        api = registrars[obj](frame, **options)

        worst = max(worst, rotation_deg(api.T_normalised[:3, :3], bench.T_template_camera[:3, :3]))
        assert np.allclose(api.T_normalised, bench.T_template_camera, rtol=0, atol=1e-9), sample_id
        # and in the model frame, mm: the normalisation undone
        R, centre, scale = ds.normalisation(obj)
        T_model = np.eye(4)
        T_model[:3, :3] = R.T @ bench.T_template_camera[:3, :3]
        T_model[:3, 3] = R.T @ (scale * bench.T_template_camera[:3, 3] + centre)
        assert np.allclose(api.T_template_camera, T_model, atol=1e-6)
    assert worst <= 1e-6, worst


@pytest.mark.data
@pytest.mark.slow
def test_the_bop_example_prints_a_pose_within_5_degrees_of_the_truth(shared_data, repo_root, tmp_path):
    import os
    import re
    import subprocess
    import sys

    root = shared_data / "bop" / "ycbv"
    script = repo_root / "examples" / "register_bop_frame.py"
    env = dict(os.environ, CATPOSE_CACHE_DIR=str(tmp_path))
    # the mustard bottle in both scenes; the master chef can is not here: ours turns it upside down on every
    # scene-1 frame, a pose its depth check cannot tell from the truth (results/search_recall/ambiguity_ycbv.md)
    for scene, im, obj in ((1, 2, 5), (2, 8, 5)):
        r = subprocess.run(
            [sys.executable, str(script), str(root), str(scene), str(im), str(obj)],
            capture_output=True,
            text=True,
            timeout=900,
            env=env,
        )
        assert r.returncode == 0, r.stderr[-2000:]
        err = float(re.search(r"error: ([0-9.]+) deg", r.stdout).group(1))
        assert err < 5.0, r.stdout
        assert re.search(r"runner-up: margin [0-9.]+, rotation error [0-9.]+ deg", r.stdout), r.stdout
    bad = subprocess.run(
        [sys.executable, str(script), str(root), "1", "2", "14"], capture_output=True, text=True, timeout=600
    )
    assert bad.returncode == 2 and "shows 0 instance(s) of object 14 (objects shown: [1, 5" in bad.stderr


@pytest.fixture(scope="module")
def generated():
    """The first samples of ``bench run dataset=synthetic`` (rendered views of procedural shapes)."""
    from catpose.bench.run.config import compose_and_build

    _, ((_, ds), (_, protocol)) = compose_and_build(["dataset=synthetic", "seed=0"], ("dataset", "protocol"))
    return [protocol.load(ds, sid).problem for sid in protocol.sample_ids(ds)[::16]]


def _bench_method(name: str):
    from catpose.bench.run.config import compose_and_build

    return compose_and_build([f"method={name}", "seed=0"], ("method",))[1][0][1]


def _seeded(method, problem):
    from catpose.geometry import seed_everything, stable_seed

    seed_everything(stable_seed(0, problem.sample_id))  # as bench run seeds a sample
    return method.register(problem).T_template_camera


@pytest.mark.parametrize("name", ["icp", "gicp", pytest.param("ours", marks=pytest.mark.slow)])
def test_the_api_method_is_bench_runs_on_generated_frames(generated, name):
    bench, api = _bench_method(name), catpose.build_method(name)
    for problem in generated:
        assert np.array_equal(_seeded(api, problem), _seeded(bench, problem)), problem.sample_id


@pytest.mark.parametrize("name", ["icp", "gicp"])
def test_register_from_points_is_bench_run_on_generated_frames(generated, name):
    """No depth image and no randomness in these methods: the points, normals and up of each sample
    through ``catpose.Registrar`` (the template already normalised) give the bench's pose."""
    from catpose.api.inputs import NormalisedTemplate

    bench = _bench_method(name)
    for problem in generated:
        template = NormalisedTemplate(problem.template, np.eye(3), np.zeros(3), 1.0)
        r = catpose.Registrar(template, name)(
            problem.points_camera,
            up=problem.ground_normal_camera,
            observation_normals=problem.normals_camera,
            max_points=len(problem.points_camera),
        )
        assert np.allclose(r.T_normalised, _seeded(bench, problem), rtol=0, atol=1e-9), problem.sample_id


@pytest.mark.slow
def test_register_a_generated_depth_frame_equals_bench_run(bop_root):
    """The shared-frames test above on a BOP scene rendered here (a box and a cylinder on a table,
    tests/test_loaders_bop.py): every instance through ``bench run dataset=bop`` and through
    ``catpose.register(DepthFrame)`` with the default method, ours, gives the same pose."""
    from catpose.bench.run.config import compose_and_build
    from catpose.geometry import seed_everything, stable_seed

    _, ((_, ds), (_, protocol), (_, method)) = compose_and_build(
        ["dataset=bop", f"dataset.root={bop_root}", "dataset.categories={1:box,2:can}", "method=ours", "seed=0"],
        ("dataset", "protocol", "method"),
    )
    ids = protocol.sample_ids(ds)
    assert len(ids) == 2
    for sample_id in ids:
        sample = protocol.load(ds, sample_id)
        seed_everything(stable_seed(0, sample_id))
        bench = method.register(sample.problem)
        frame, template, options = api_inputs(ds, sample_id, int(sample.info["obj_id"]))
        api = catpose.Registrar(template, "ours")(frame, **options)
        assert np.allclose(api.T_normalised, bench.T_template_camera, rtol=0, atol=1e-9), sample_id
