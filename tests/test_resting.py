"""Stable resting directions (catpose.resting) and the ones ours searches (methods/ours/resting.py)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from catpose.methods.ours.resting import rotation_between, ups
from catpose.methods.ours.settings import RestingSettings
from catpose.resting import resting_ups, up_classes
from catpose.types import Template


def _box(extents) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=extents)


def test_a_box_rests_on_its_six_faces_the_largest_most_often():
    ups = resting_ups(_box([1.0, 2.0, 3.0]).vertices)
    vectors = np.array([r.up for r in ups])
    assert len(ups) == 6 and sum(r.probability for r in ups) == pytest.approx(1.0, abs=1e-6)
    # every up is a face normal: a signed coordinate axis
    assert np.allclose(np.sort(np.abs(vectors), axis=1), [[0, 0, 1]] * 6, atol=1e-6)
    # lying on the 2 x 3 face (up = +-x) is the most probable, on the 1 x 2 face (up = +-z) the least
    assert abs(ups[0].up[0]) == pytest.approx(1.0) and abs(ups[-1].up[2]) == pytest.approx(1.0)
    assert ups[0].probability > ups[2].probability > ups[4].probability


def test_a_cube_rests_on_each_face_alike():
    probs = [r.probability for r in resting_ups(_box([1.0, 1.0, 1.0]).vertices)]
    assert np.allclose(probs, 1 / 6, atol=1e-3)


def test_a_cylinders_side_poses_merge_into_one_class_under_its_symmetry():
    cyl = trimesh.creation.cylinder(radius=0.3, height=1.0, sections=32)
    ups = resting_ups(cyl.vertices)
    assert len(ups) > 3  # each side facet is its own face
    classes = up_classes(ups, np.array([0.0, 0.0, 1.0]))
    angles = sorted(round(float(np.degrees(np.arccos(np.clip(r.up[2], -1, 1))))) for r in classes)
    assert angles == [0, 90, 180]  # upright, on its side, upside down
    side = next(r for r in classes if abs(r.up[2]) < 0.5)
    assert side.probability == pytest.approx(sum(r.probability for r in ups if abs(r.up[2]) < 0.5), abs=1e-6)


def test_rotation_between_takes_a_onto_b_including_opposite_vectors():
    rng = np.random.default_rng(0)
    for a, b in [(rng.normal(size=3), rng.normal(size=3)), ([0, 0, 1.0], [0, 0, -1.0]), ([1.0, 0, 0], [1.0, 0, 0])]:
        R = rotation_between(np.asarray(a), np.asarray(b))
        np.testing.assert_allclose(
            R @ (np.asarray(a) / np.linalg.norm(a)), np.asarray(b) / np.linalg.norm(b), atol=1e-12
        )
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)


def _template(mesh: trimesh.Trimesh, axis=None) -> Template:
    pts, idx = trimesh.sample.sample_surface_even(mesh, 600, seed=1)
    return Template(
        "test/box", "box", pts, mesh.face_normals[idx], vertices=mesh.vertices, triangles=mesh.faces, symmetry_axis=axis
    )


def test_resting_directions_start_with_the_templates_up():
    tpl = _template(_box([0.6, 1.0, 1.4]))
    found = ups(tpl, RestingSettings(max_poses=3, min_probability=0.0))
    assert found.shape == (4, 3) and np.allclose(found[0], [0, 0, 1])
    np.testing.assert_allclose(np.linalg.norm(found, axis=1), 1.0, atol=1e-12)
    assert ups(tpl, RestingSettings(max_poses=0)).shape == (1, 3)


def test_resting_directions_of_a_symmetric_template_skip_what_its_symmetry_makes_equal():
    cyl = trimesh.creation.cylinder(radius=0.3, height=1.0, sections=32)
    found = ups(_template(cyl, axis=np.array([0.0, 0.0, 1.0])), RestingSettings(max_poses=5, min_probability=0))
    angles = sorted(round(float(np.degrees(np.arccos(np.clip(u[2], -1, 1))))) for u in found)
    assert angles == [0, 90, 180]


def test_a_flat_model_is_refused_at_once_not_searched_forever():
    """Issue 60 case 23: trimesh's stable-pose search never ends on a hull of no volume."""
    import time

    from catpose.errors import InvalidInputError

    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)  # two triangles, a unit square
    start = time.monotonic()
    with pytest.raises(InvalidInputError, match="flat or degenerate"):
        resting_ups(square)
    assert time.monotonic() - start < 5
    assert len(resting_ups(np.vstack([square, square + [0, 0, 1e-3]]))) >= 2  # thin, yet solid
