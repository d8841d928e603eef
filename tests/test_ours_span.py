"""Ours' first depth stage: the mask and points cut to the object's depth span
(:mod:`catpose.methods.ours.span`)."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import CAMERA, chair_template, rotation_error_deg  # noqa: E402
from test_ours_depth import _ours, scene_problem  # noqa: E402

from catpose.datasets.render import depth_to_points, estimate_normals  # noqa: E402
from catpose.methods.ours import span  # noqa: E402
from catpose.types import DepthImage  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread", "private_cache_dir")


@pytest.fixture(scope="module")
def template():
    return chair_template()


def far_bleed(problem, metres_behind: float = 20.0, radius_px: int = 9):
    """``problem`` whose mask also holds a disc of background pixels just right of the object,
    ``metres_behind`` object units behind its median depth, their points joined to the cloud."""
    image = problem.depth_image
    rows, cols = np.nonzero(image.mask)
    r, c = int(np.median(rows)), int(cols.max()) + radius_px
    yy, xx = np.mgrid[: image.mask.shape[0], : image.mask.shape[1]]
    blob = ((yy - r) ** 2 + (xx - c) ** 2 <= radius_px**2) & ~image.mask
    depth = image.depth.copy()
    depth[blob] = float(np.median(image.depth[image.mask])) + metres_behind
    far_points, _ = depth_to_points(depth, CAMERA, blob)
    points = np.concatenate([problem.points_camera, far_points])
    problem = replace(
        problem,
        points_camera=points,
        normals_camera=estimate_normals(points, 0.06),
        depth_image=DepthImage(depth, image.K, image.mask | blob),
    )
    return problem, int(blob.sum()), len(far_points)


def test_the_far_points_go_and_nothing_else(template):
    clean, _ = scene_problem(template, 0)
    same, n = span.observed_points(clean)
    assert same is clean and n == 0  # nothing far: the problem itself
    dirty, _, n_points = far_bleed(clean)
    kept, n = span.observed_points(dirty)
    assert n == n_points > 0
    np.testing.assert_array_equal(kept.points_camera, clean.points_camera)
    assert kept.depth_image is dirty.depth_image  # the check's mask stays: a far pixel costs every pose alike


def test_the_poor_fit_test_counts_only_the_pixels_in_the_span(template):
    from catpose.methods.ours.check import DepthVerifier

    clean, T = scene_problem(template, 0)
    dirty, n_blob, _ = far_bleed(clean, radius_px=25)
    fits = [DepthVerifier(template, p.depth_image, tau=0.15).fit(T[None], 0.3, 3)[0, 0] for p in (clean, dirty)]
    assert fits[0] > 0.9 and abs(fits[1] - fits[0]) < 0.02
    L = DepthVerifier(template, dirty.depth_image).lattice
    assert (L.mask & ~span.in_span(L.depth, span.median_depth(dirty.depth_image))).any()  # the blob is on the lattice


def test_a_far_bleed_moves_ours_answer_only_without_the_span(template, monkeypatch):
    p, T = scene_problem(template, 1, up_object=(1.0, 0.0, 0.0))
    dirty, _, n_points = far_bleed(p)
    r = _ours().register(dirty)
    assert r.extras["depth_far_points"] == n_points
    assert rotation_error_deg(r.T_template_camera[:3, :3], T[:3, :3]) < 10.0
    monkeypatch.setattr(span, "observed_points", lambda problem: (problem, 0))
    monkeypatch.setattr(span, "in_span", lambda depth, z: np.ones(np.shape(depth), bool))
    r = _ours().register(dirty)
    assert rotation_error_deg(r.T_template_camera[:3, :3], T[:3, :3]) > 10.0
