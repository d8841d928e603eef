"""The optional depth image of a problem (catpose.types.DepthImage): validation, datasets that fill
it, golden inputs that store it."""

from __future__ import annotations

import numpy as np
import pytest

from catpose.bench.protocols import GtModel
from catpose.bench.regress.golden import perturbed, read_golden, write_golden
from catpose.datasets.render import PinholeCamera, depth_to_points
from catpose.datasets.synthetic import SyntheticDataset
from catpose.datasets.views import ViewOptions
from catpose.errors import InvalidInputError
from catpose.types import DepthImage

K = np.array([[100.0, 0, 15.5], [0, 100.0, 11.5], [0, 0, 1]])


@pytest.mark.parametrize(
    "depth,mask,K_,needle",
    [
        (np.full((4, 4), np.nan), np.ones((4, 4), bool), K, "NaN"),
        (-np.ones((4, 4)), np.ones((4, 4), bool), K, "negative"),
        (np.ones((4, 4)), np.ones((3, 4), bool), K, "mask"),
        (np.ones((4, 4)), np.ones((4, 4), bool), np.diag([0.0, 1.0, 1.0]), "focal"),
        (np.ones(4), np.ones(4, bool), K, "shape"),
    ],
)
def test_bad_depth_images_are_refused_in_one_line(depth, mask, K_, needle):
    with pytest.raises(InvalidInputError, match=needle):
        DepthImage(depth, K_, mask)


@pytest.mark.parametrize("sensor", ["none", "kinect"])
def test_synthetic_views_carry_the_image_their_points_came_from(sensor):
    ds = SyntheticDataset(
        seed=0,
        categories=["mug"],
        instances_per_category=1,
        views_per_instance=1,
        view=ViewOptions(max_points=10**6),
        sensor=sensor,
    )
    s = GtModel().load(ds, ds.observation_ids()[0])
    di = s.problem.depth_image
    assert di is not None and di.mask.any()
    cam = PinholeCamera.from_K(di.K, di.depth.shape[1], di.depth.shape[0])
    pts, _ = depth_to_points(di.depth, cam, di.mask)
    # every observed point is a back-projected mask pixel (no subsampling: max_points is large)
    assert len(pts) == len(s.problem.points_camera)
    np.testing.assert_allclose(np.sort(pts[:, 2]), np.sort(s.problem.points_camera[:, 2]), atol=1e-9)


def test_golden_inputs_keep_depth_images_and_meshes(tmp_path):
    ds = SyntheticDataset(seed=0, categories=["can"], instances_per_category=1, views_per_instance=1)
    sample = GtModel().load(ds, ds.observation_ids()[0])
    path = write_golden(tmp_path / "g.npz", "t", [], [sample])
    back = read_golden(path)[0]
    di, db = sample.problem.depth_image, back.problem.depth_image
    np.testing.assert_allclose(db.depth, di.depth.astype(np.float32), atol=0)
    assert np.array_equal(db.mask, di.mask) and np.allclose(db.K, di.K)
    assert back.problem.template.has_mesh
    np.testing.assert_array_equal(back.problem.template.triangles, sample.problem.template.triangles)
    moved = perturbed(back, 1e-12, 0)
    assert moved.problem.depth_image is not None and moved.problem.template.has_mesh
