"""The occlusion-aware depth check (methods/ours/check.py) against a brute-force reference, and
its behaviour under occlusion, free-space violation and half turns."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from catpose.datasets.render import PinholeCamera, render_depth
from catpose.geometry import compose_T, invert_T, make_T
from catpose.methods.ours.check import DepthVerifier
from catpose.methods.pose_scores import half_turns
from catpose.types import DepthImage, Template

CAM = PinholeCamera(160, 120, 150.0, 150.0, 79.5, 59.5)


def _template() -> Template:
    """An asymmetric object: a box with a block on one side (unit-sphere sized)."""
    body = trimesh.creation.box(extents=[0.8, 0.5, 1.0])
    knob = trimesh.creation.box(extents=[0.3, 0.3, 0.3])
    knob.apply_translation([0.5, 0.0, 0.2])
    mesh = trimesh.util.concatenate([body, knob])
    pts, idx = trimesh.sample.sample_surface_even(mesh, 800, seed=0)
    return Template("test/knob", "box", pts, mesh.face_normals[idx], vertices=mesh.vertices, triangles=mesh.faces)


def _view(tpl: Template, occluder: bool = False):
    """Depth image (object + a table-like backdrop, optionally an occluder in front of part of the
    object), the object's visible mask, and the true ``T_template_camera``."""
    from catpose.geometry import look_at_T_camera_world

    T_cam_obj = look_at_T_camera_world(np.array([2.2, 1.4, 1.2]), np.zeros(3), np.array([0.0, 0.0, 1.0]))
    obj = render_depth(tpl.vertices, tpl.triangles, T_cam_obj, CAM).astype(float)
    back = trimesh.creation.box(extents=[8.0, 8.0, 0.02])
    back.apply_translation([0, 0, -0.51])
    scene = [obj, render_depth(back.vertices, back.faces, T_cam_obj, CAM).astype(float)]
    if occluder:
        occ = trimesh.creation.box(extents=[0.3, 0.3, 1.4])
        occ.apply_translation([0.9, 0.55, 0.1])
        scene.append(render_depth(occ.vertices, occ.faces, T_cam_obj, CAM).astype(float))
    stack = np.stack(scene)
    depth = np.where(stack > 0, stack, np.inf).min(axis=0)
    depth = np.where(np.isfinite(depth), depth, 0.0)
    mask = (obj > 0) & (obj <= depth + 1e-9)
    return DepthImage(depth, CAM.K, mask), invert_T(T_cam_obj)


def _reference(tpl: Template, image: DepthImage, T_template_camera: np.ndarray, tau: float, stride: int) -> float:
    """The score from a full-image rendering (render_depth), every stride-th pixel."""
    r = render_depth(tpl.vertices, tpl.triangles, invert_T(T_template_camera), CAM).astype(float)[::stride, ::stride]
    o, m = image.depth[::stride, ::stride], image.mask[::stride, ::stride]
    hit = r > 0
    mask_cost = np.where(hit, np.minimum(np.abs(r - o), tau) / tau, 1.0)[m].sum()
    free = (~m & hit & (o > 0) & (o - r > tau)).sum()
    return float((mask_cost + free) / m.sum())


def test_scores_equal_a_full_image_rendering():
    tpl = _template()
    image, T_true = _view(tpl, occluder=True)
    v = DepthVerifier(tpl, image, tau=0.05, target_pixels=10**6, max_rays=10**6)
    assert v.lattice.stride == 1
    poses = [T_true, compose_T(make_T(np.eye(3), [0.05, -0.03, 0.02]), T_true)] + [
        compose_T(F, T_true) for F in half_turns()[1:]
    ]
    got = v.scores(np.stack(poses))
    want = [_reference(tpl, image, T, 0.05, 1) for T in poses]
    np.testing.assert_allclose(got, want, atol=1e-5)  # render_depth returns float32 depth


def test_the_true_pose_wins_over_its_half_turns_and_a_shift():
    tpl = _template()
    image, T_true = _view(tpl)
    v = DepthVerifier(tpl, image, tau=0.05)
    s = v.scores(
        np.stack(
            [T_true]
            + [compose_T(F, T_true) for F in half_turns()[1:]]
            + [compose_T(make_T(np.eye(3), [0.0, 0.0, 0.15]), T_true)]
        )
    )
    assert s[0] < 0.02 and (s[1:] > 0.1).all()


def test_a_hidden_side_costs_the_true_pose_nothing():
    """The occluder hides part of the object: the true pose renders surface behind it, which is
    not held against it (the visibility-aware Chamfer would)."""
    tpl = _template()
    clear, T_true = _view(tpl)
    hidden, _ = _view(tpl, occluder=True)
    assert hidden.mask.sum() < 0.9 * clear.mask.sum()
    assert DepthVerifier(tpl, hidden, tau=0.05).scores(T_true[None])[0] < 0.02


def test_surface_in_front_of_the_observation_is_a_free_space_violation():
    tpl = _template()
    image, T_true = _view(tpl)
    T_near = invert_T(compose_T(make_T(np.eye(3), [0.0, 0.0, -0.3]), invert_T(T_true)))  # 0.3 nearer the camera
    v = DepthVerifier(tpl, image, tau=0.05, target_pixels=10**6, max_rays=10**6)
    win, r = v.render(T_near[None])[0]
    o, m = v.lattice.depth[win], v.lattice.mask[win]
    assert ((~m) & (r > 0) & (o - r > 0.05)).sum() > 0
    assert v.fit(T_near[None])[0, 1] > 0.05 and v.fit(T_true[None])[0, 1] < 0.01


def test_the_lattice_keeps_the_ray_budget():
    tpl = _template()
    image, T_true = _view(tpl)
    v = DepthVerifier(tpl, image, target_pixels=50, max_rays=200)
    assert v.lattice.stride > 1 and v.mask_pixels >= 20
    win, r = v.render(T_true[None])[0]
    assert r.size <= 4 * 200


def test_an_empty_mask_is_refused():
    tpl = _template()
    image, _ = _view(tpl)
    with pytest.raises(ValueError, match="mask"):
        DepthVerifier(tpl, DepthImage(image.depth, image.K, np.zeros_like(image.mask)))


def test_a_pose_rendered_lately_is_not_cast_again(monkeypatch):
    """Scoring a pose and then measuring its fit casts it once; a batch larger than the kept
    renderings still scores every pose, the same as one by one."""
    from catpose.methods.ours import check as depth_check

    tpl = _template()
    image, T_gt = _view(tpl)
    v = DepthVerifier(tpl, image, tau=0.1, target_pixels=300)
    casts = []
    real_cast = v.caster.cast
    monkeypatch.setattr(v.caster, "cast", lambda o, d: casts.append(len(o)) or real_cast(o, d))
    s = v.scores(T_gt[None])
    f = v.fit(T_gt[None])
    assert len(casts) == 1 and s[0] < 0.05 and f[0, 0] > 0.9
    shifted = [compose_T(make_T(np.eye(3), [0.01 * k, 0.0, 0.0]), T_gt) for k in range(depth_check.RENDERS_KEPT + 4)]
    many = v.scores(np.stack(shifted))
    fresh = DepthVerifier(tpl, image, tau=0.1, target_pixels=300)
    np.testing.assert_array_equal(many, [fresh.scores(T[None])[0] for T in shifted])
    assert v.scores(T_gt[None])[0] == s[0]


def test_the_inner_fit_ignores_a_mask_that_bleeds_over_its_edge():
    """A segmentation grown by 2 px onto the backdrop (real masks' edges are off by a pixel or two)
    leaves the true pose's whole-mask fit at about 0.9; counted 3 px inside the mask's edge it is
    over 0.99 again, while a pose half a turn off stays short inside too (the erosion is a reference:
    scipy.ndimage, pixel by pixel; the span, 2 object units of the mask's median depth, numpy's)."""
    from scipy.ndimage import binary_dilation, binary_erosion

    tpl = _template()
    image, T_true = _view(tpl)
    bled = DepthImage(image.depth, image.K, binary_dilation(image.mask, iterations=2) & (image.depth > 0))
    v = DepthVerifier(tpl, bled, tau=0.05, target_pixels=10**6, max_rays=10**6)  # stride 1: every pixel
    whole, inner = v.fit(T_true[None], 0.05)[0, 0], v.fit(T_true[None], 0.05, 3)[0, 0]
    assert whole < 0.95 and inner > 0.99
    # the denominator: the eroded mask's pixels within the object's depth span (the backdrop's are not)
    inner_px = binary_erosion(bled.mask, iterations=3) & (np.abs(bled.depth - np.median(bled.depth[bled.mask])) <= 2)
    assert inner_px.sum() < binary_erosion(bled.mask, iterations=3).sum()
    n_inner = int(inner_px.sum())
    win, r = v.render(T_true[None])[0]
    inside = inner_px[win]
    assert inner == pytest.approx(((r > 0) & (np.abs(r - bled.depth[win]) <= 0.05) & inside).sum() / n_inner)
    T_turned = compose_T(half_turns()[1], T_true)
    assert v.fit(T_turned[None], 0.05, 3)[0, 0] < 0.9
    # an erosion that leaves nothing falls back to the whole mask (within the span)
    in_span = bled.mask & (np.abs(bled.depth - np.median(bled.depth[bled.mask])) <= 2)
    explained = ((r > 0) & (np.abs(r - bled.depth[win]) <= 0.05) & in_span[win]).sum()
    assert v.fit(T_true[None], 0.05, 10**4)[0, 0] == pytest.approx(explained / in_span.sum())


def test_the_rays_left_uncast_change_no_cost_and_no_fit():
    """Rendering with a tolerance casts only the rays that can change a cost or a fit of that
    tolerance (and larger ones): every pose's costs and fits are those of the whole rendering,
    bit for bit, while pixels whose depth lies in front of the template's box (the occluder) are
    not cast."""
    from scipy.spatial.transform import Rotation

    from catpose.methods.ours.check_kernel import window_cost, window_fit

    tpl = _template()
    image, T_true = _view(tpl, occluder=True)
    v = DepthVerifier(tpl, image, tau=0.05, target_pixels=10**6, max_rays=10**6)
    rng = np.random.default_rng(0)
    moves = [make_T(Rotation.random(random_state=k).as_matrix(), rng.normal(0.0, 0.3, 3)) for k in range(30)]
    poses = np.stack([T_true] + [compose_T(F, T_true) for F in [*half_turns()[1:], *moves]])
    full, pruned = v.render(poses), v.render(poses, 0.05)
    skipped = 0
    for (win, r), (win2, r2) in zip(full, pruned):
        assert win == win2
        if win is None:
            continue
        o, m = v.lattice.depth[win], v.lattice.mask[win]
        for tol in (0.05, 0.2):
            a, b = window_cost(o, m, r, tol), window_cost(o, m, r2, tol)
            assert a[1] == b[1] and np.array_equal(a[0], b[0])
            assert window_fit(o, m, m, r, tol) == window_fit(o, m, m, r2, tol)
        assert np.array_equal(r2[r2 > 0], r[r2 > 0])
        skipped += int(((r > 0) & (r2 == 0)).sum())
    assert skipped > 0
