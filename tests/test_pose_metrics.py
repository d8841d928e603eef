"""Standard pose metrics against computations that share no code with them.

References used here: brute-force all-pairs distances (ADD-S, MSSD), an explicit enumeration of
the cube's 24 rotations and of a cylinder's spins written out with cos/sin, and values worked out
by hand for a cube, a cylinder and a fronto-parallel plate at known poses.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from catpose.bench.scoring import pose_metrics as pm


def _rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _cube_points(n: int = 5) -> np.ndarray:
    """Points on the surface of the cube [-1, 1]^3 (grid on each face), corners included."""
    g = np.linspace(-1.0, 1.0, n)
    pts = {tuple(p) for p in itertools.product(g, g, g) if np.max(np.abs(p)) == 1.0}
    return np.array(sorted(pts))


def _cube_rotations() -> list[np.ndarray]:
    """The 24 proper rotations of the cube: signed permutation matrices with det +1."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product([-1.0, 1.0], repeat=3):
            M = np.zeros((3, 3))
            for i, j in enumerate(perm):
                M[i, j] = signs[i]
            if np.linalg.det(M) > 0:
                out.append(M)
    return out


def _cylinder_points(r: float = 30.0, h: float = 50.0, offset=(0.0, 0.0, 0.0), n_ring: int = 36) -> np.ndarray:
    a = np.radians(np.arange(n_ring) * 360.0 / n_ring)
    rings = [np.stack([r * np.cos(a), r * np.sin(a), np.full_like(a, z)], 1) for z in (-h, 0.0, h)]
    return np.concatenate(rings) + np.asarray(offset)


def _brute_adi(P_est: np.ndarray, P_gt: np.ndarray) -> float:
    """ADD-S by the definition: for each ground-truth point, the nearest estimated point."""
    d = np.sqrt(((P_est[:, None, :] - P_gt[None, :, :]) ** 2).sum(-1))  # d[i, j] = |est_i - gt_j|
    return float(d.min(axis=0).mean())


def test_adi_goes_from_each_ground_truth_point_to_the_nearest_estimated_point():
    """A case where the two directions differ, worked out by hand.

    Model points on the y axis: p0 = (0,0,0), p1 = (0,1,0), p2 = (0,2,0). Ground truth: identity,
    so the gt points are (0,0), (0,1), (0,2) (z = 0 throughout). Estimate: a quarter turn about z,
    (x, y) -> (-y, x), then t = (1, 0, 0): p0 -> (1,0), p1 -> (0,0), p2 -> (-1,0), a segment on
    the x axis.

    ADD-S (Hinterstoisser et al. 2012; bop_toolkit pose_error.adi), gt -> nearest estimated:
      (0,0) -> (0,0): 0;  (0,1) -> (0,0): 1;  (0,2) -> (0,0): 2;   mean = 3 / 3 = 1.
    The other direction, estimated -> nearest gt (what this function computed before):
      (1,0) -> (0,0): 1;  (0,0) -> (0,0): 0;  (-1,0) -> (0,0): 1;  mean = 2 / 3.
    """
    P = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0]])
    quarter_turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert pm.adi(quarter_turn, [1.0, 0.0, 0.0], np.eye(3), np.zeros(3), P) == pytest.approx(1.0, abs=1e-12)
    # swapping the roles of estimate and truth gives the other direction's value, 2/3
    assert pm.adi(np.eye(3), np.zeros(3), quarter_turn, [1.0, 0.0, 0.0], P) == pytest.approx(2.0 / 3.0, abs=1e-12)


def test_add_and_adi_on_a_cube_by_hand():
    P = _cube_points(2)  # the 8 corners
    I, z = np.eye(3), np.zeros(3)
    # shifted by 3 along x: every point moves 3; nearest gt corner is 1 away (x = 2) or 3 away (x = 4)
    assert pm.add(I, [3.0, 0, 0], I, z, P) == pytest.approx(3.0)
    assert pm.adi(I, [3.0, 0, 0], I, z, P) == pytest.approx(2.0)
    # a quarter turn about z: each corner moves to a neighbouring corner 2 away; as a set nothing moves
    assert pm.add(_rot_z(90), z, I, z, P) == pytest.approx(2.0)
    assert pm.adi(_rot_z(90), z, I, z, P) == pytest.approx(0.0, abs=1e-12)


def test_adi_and_mssd_match_brute_force():
    rng = np.random.default_rng(3)
    P = rng.normal(size=(300, 3)) * [40.0, 20.0, 10.0]
    for _ in range(5):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        w, x, y, zq = q
        R = np.array(
            [
                [1 - 2 * (y * y + zq * zq), 2 * (x * y - zq * w), 2 * (x * zq + y * w)],
                [2 * (x * y + zq * w), 1 - 2 * (x * x + zq * zq), 2 * (y * zq - x * w)],
                [2 * (x * zq - y * w), 2 * (y * zq + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        t_est, t_gt = rng.normal(size=3) * 10, rng.normal(size=3) * 10
        R_gt = _rot_x(rng.uniform(0, 360)) @ _rot_z(rng.uniform(0, 360))
        P_est, P_gt = P @ R.T + t_est, P @ R_gt.T + t_gt
        assert pm.adi(R, t_est, R_gt, t_gt, P) == pytest.approx(_brute_adi(P_est, P_gt), rel=1e-12)
        assert pm.add(R, t_est, R_gt, t_gt, P) == pytest.approx(np.mean(np.linalg.norm(P_est - P_gt, axis=1)))
        # MSSD without symmetries: plain maximum of corresponding-point distances
        assert pm.mssd(R, t_est, R_gt, t_gt, P) == pytest.approx(np.max(np.linalg.norm(P_est - P_gt, axis=1)))


def test_mssd_over_cube_symmetries_equals_explicit_enumeration():
    P = _cube_points(4)
    rots = _cube_rotations()
    assert len(rots) == 24
    discrete = []
    for M in rots:
        if np.allclose(M, np.eye(3)):
            continue
        S = np.eye(4)
        S[:3, :3] = M
        discrete.append(S.reshape(-1).tolist())
    syms = pm.symmetry_transforms(discrete=discrete)
    assert len(syms) == 24
    rng = np.random.default_rng(0)
    for _ in range(4):
        R_est = _rot_z(rng.uniform(-60, 60)) @ _rot_x(rng.uniform(-60, 60))
        t_est = rng.normal(size=3)
        R_gt, t_gt = _rot_x(20.0), np.array([0.0, 0.0, 10.0])
        expected = min(np.max(np.linalg.norm((P @ R_est.T + t_est) - (P @ (R_gt @ M).T + t_gt), axis=1)) for M in rots)
        assert pm.mssd(R_est, t_est, R_gt, t_gt, P, syms) == pytest.approx(expected, rel=1e-12)
    # a quarter turn of a cube is no error at all; without its symmetries it is the corner move
    assert pm.mssd(_rot_z(90), np.zeros(3), np.eye(3), np.zeros(3), P, syms) == pytest.approx(0.0, abs=1e-9)
    assert pm.mssd(_rot_z(90), np.zeros(3), np.eye(3), np.zeros(3), P) == pytest.approx(2.0)
    # 5 degree 5 cm: symmetric gt poses count (cube side 2 m with unit_mm = 1000)
    assert pm.n_deg_m_cm(_rot_z(92), [0, 0, 0.01], np.eye(3), np.zeros(3), 5, 5, unit_mm=1000, symmetries=syms)
    assert not pm.n_deg_m_cm(_rot_z(92), [0, 0, 0.01], np.eye(3), np.zeros(3), 5, 5, unit_mm=1000)
    assert not pm.n_deg_m_cm(_rot_z(92), [0, 0, 0.06], np.eye(3), np.zeros(3), 5, 5, unit_mm=1000, symmetries=syms)


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (12.0, -7.0, 0.0)])
def test_cylinder_spin_about_its_offset_axis_is_free(offset):
    r, h = 30.0, 50.0
    P = _cylinder_points(r, h, offset)
    cont = [{"axis": [0, 0, 1], "offset": list(offset)}]
    syms = pm.symmetry_transforms(continuous=cont)
    assert len(syms) == math.ceil(math.pi / 0.01)
    # every symmetry keeps points on the cylinder: same height and distance from the offset axis
    for S in syms[::37]:
        Q = P @ S[:3, :3].T + S[:3, 3]
        assert np.allclose(Q[:, 2], P[:, 2])
        assert np.allclose(np.linalg.norm(Q[:, :2] - offset[:2], axis=1), r)
    # the estimate spins the cylinder by 37 degrees about its own (offset) axis
    spin = _rot_z(37.0)
    o = np.asarray(offset)
    R_est, t_est = spin, o - spin @ o
    step = 2 * math.pi / len(syms)
    bound = 2 * r * math.sin(step / 4) + 1e-9  # half a discretisation step, worst case
    assert pm.mssd(R_est, t_est, np.eye(3), np.zeros(3), P, syms) <= bound
    # hand value without symmetries: a rim point moves by the chord 2 r sin(37/2)
    assert pm.mssd(R_est, t_est, np.eye(3), np.zeros(3), P) == pytest.approx(
        2 * r * math.sin(math.radians(18.5)), rel=1e-9
    )
    if any(offset):  # the axis through the origin (offset ignored) is not a symmetry
        wrong = pm.symmetry_transforms(continuous=[{"axis": [0, 0, 1]}])
        assert pm.mssd(R_est, t_est, np.eye(3), np.zeros(3), P, wrong) > 5.0
    # tilting the axis by 10 degrees: rotation error 10 degrees whatever the spin
    errs = pm.rt_errors(_rot_x(10.0), np.zeros(3), np.eye(3), np.zeros(3), syms)
    assert min(e for e, _ in errs) == pytest.approx(10.0, abs=1e-6)
    assert pm.n_deg_m_cm(_rot_x(10.0) @ spin, np.zeros(3), np.eye(3), np.zeros(3), 10.5, 10, symmetries=syms)
    assert not pm.n_deg_m_cm(_rot_x(10.0) @ spin, np.zeros(3), np.eye(3), np.zeros(3), 5, 5, symmetries=syms)


def test_symmetry_enumeration_matches_explicit_cos_sin_spins():
    syms = pm.symmetry_transforms(continuous=[{"axis": [0, 0, 2.0], "offset": [0, 0, 0]}], max_sym_disc_step=0.5)
    n = math.ceil(math.pi / 0.5)  # 7 steps
    assert len(syms) == n
    for k, S in enumerate(syms):
        a = 2 * math.pi * k / n
        expected = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
        assert np.allclose(S[:3, :3], expected) and np.allclose(S[:3, 3], 0)
    # discrete x continuous: a can flipped upside down (x-axis half turn) combines with every spin
    flip = np.diag([1.0, -1.0, -1.0, 1.0])
    both = pm.symmetry_transforms(
        discrete=[flip.reshape(-1)], continuous=[{"axis": [0, 0, 1], "offset": [0, 0, 0]}], max_sym_disc_step=0.5
    )
    assert len(both) == 2 * n
    assert any(np.allclose(S, flip) for S in both)


def test_mspd_of_a_shifted_plate_by_hand():
    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    g = np.linspace(-50, 50, 5)
    P = np.array([[x, y, 0.0] for x in g for y in g])
    t_gt = np.array([0.0, 0.0, 1000.0])
    # a 10 mm shift parallel to the image plane at 1 m moves every projection by f * 10 / 1000 px
    assert pm.mspd(np.eye(3), t_gt + [10, 0, 0], np.eye(3), t_gt, K, P) == pytest.approx(5.0)
    # the plate's in-plane quarter turn is a symmetry of the square point grid
    S = np.eye(4)
    S[:3, :3] = _rot_z(90)
    syms = pm.symmetry_transforms(discrete=[S.reshape(-1)])
    assert pm.mspd(_rot_z(90), t_gt, np.eye(3), t_gt, K, P, syms) == pytest.approx(0.0, abs=1e-9)
    # without it, the corner (50, 50) goes to (-50, 50): 100 mm at 1 m = 50 px
    assert pm.mspd(_rot_z(90), t_gt, np.eye(3), t_gt, K, P) == pytest.approx(50.0)


def _plate_mesh(half: float = 50.0) -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], float)
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def test_render_depth_of_a_plate_is_its_distance():
    v, f = _plate_mesh()
    K = np.array([[500.0, 0, 64], [0, 500.0, 48], [0, 0, 1]])
    d = pm.render_depth(v, f, np.eye(3), [0, 0, 1000.0], K, 128, 96)
    inside = d > 0
    assert np.allclose(d[inside], 1000.0, atol=1e-3)
    # the plate spans 100 mm at 1 m: 50 px each way, centred on the principal point
    assert inside.sum() == pytest.approx(50 * 50, rel=0.05)


def test_vsd_on_a_fronto_parallel_plate_by_hand():
    v, f = _plate_mesh()
    K = np.array([[500.0, 0, 64], [0, 500.0, 48], [0, 0, 1]])
    I, t_gt = np.eye(3), np.array([0.0, 0, 1000.0])
    depth_test = pm.render_depth(v, f, I, t_gt, K, 128, 96)
    assert pm.vsd(I, t_gt, I, t_gt, depth_test, K, v, f, taus=[20.0]) == [0.0]
    # 30 mm further away: every overlapping pixel differs by >= 30 mm, so with tau 20 all are wrong;
    # with tau 50 only the part of the gt plate not covered by the smaller far plate is wrong
    far = t_gt + [0, 0, 30.0]
    e20, e50 = pm.vsd(I, far, I, t_gt, depth_test, K, v, f, taus=[20.0, 50.0])
    assert e20 == 1.0
    assert e50 == pytest.approx(1 - (1000 / 1030) ** 2, abs=0.02)
    # normalised by a diameter of 100 mm: tau 0.5 = 50 mm, same as above
    assert pm.vsd(I, far, I, t_gt, depth_test, K, v, f, taus=[0.5], diameter=100.0)[0] == pytest.approx(e50)
    # a 10 mm shift sideways (5 px at f = 500): the two 50-px squares overlap in 45 x 50 px
    e = pm.vsd(I, t_gt + [10, 0, 0], I, t_gt, depth_test, K, v, f, taus=[5.0])[0]
    assert e == pytest.approx(1 - 45 * 50 / (55 * 50), abs=0.02)


def test_recalls_at_bop19_thresholds_by_hand():
    import pandas as pd

    from catpose.bench.scoring.bop_eval import metric_value

    # diameter 200 mm: MSSD thresholds 10..100 mm; 1280 px wide: MSPD thresholds 10..100 px
    # errors 15 and 55, one missing (NaN): below 10 -> 0; 20..50 -> 1/3; 60..100 -> 2/3
    errs = [15.0, 55.0, float("nan")]
    expected = (0 + 4 * (1 / 3) + 5 * (2 / 3)) / 10
    df = pd.DataFrame({"mssd": errs, "diameter": 200.0, "mspd": errs, "im_width": 1280})
    assert metric_value(df, "ar_mssd") == pytest.approx(expected)
    assert metric_value(df, "ar_mspd") == pytest.approx(expected)
    assert pm.recall([10.0], 10.0) == 0.0  # BOP counts e < th
    # VSD: two instances with per-tau errors 0 and 0.3: the second is correct at th 0.35..0.5 (4 of 10)
    assert pm.average_recall_vsd([[0.0] * 10, [0.3] * 10]) == pytest.approx((1.0 + 0.4) / 2)


def test_every_continuous_axis_is_used_with_its_offset():
    c = np.array([3.0, -2.0, 5.0])  # a sphere centred off the origin: symmetric about any axis through c
    axes = [{"axis": [0, 0, 1], "offset": c.tolist()}, {"axis": [1, 0, 0], "offset": c.tolist()}]
    syms = pm.symmetry_transforms(continuous=axes, max_sym_disc_step=0.5)
    n = math.ceil(math.pi / 0.5)
    assert len(syms) == 1 + 2 * (n - 1)
    for S in syms:
        assert np.allclose(S[:3, :3] @ c + S[:3, 3], c)  # the centre stays: offsets are applied
    rotation_axes = {tuple(np.round(np.linalg.svd(S[:3, :3] - np.eye(3))[2][-1] ** 2, 6)) for S in syms[1:]}
    assert rotation_axes == {(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)}  # both axes, not only the first
