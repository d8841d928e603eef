"""The kernels' threads (:mod:`catpose.kernel_threads`): contiguous ranges of independent starts on
a small pool, and every kernel split that way gives the same bits on 1, 2 or 3 threads (point-to-
plane and yaw ICP, the IRLS kernel, the Chamfer and visibility scores), so does ours' whole
``register``."""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from catpose import cell_grid, extras, kernel_threads
from catpose.geometry import make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _clouds import box_cloud  # noqa: E402

COUNTS = (1, 2, 3)


@contextmanager
def threads(n: int | None) -> Iterator[None]:
    """The runs' ``threads`` key set to ``n`` inside the block, kernels' and torch's counts restored after."""
    before, torch_before = kernel_threads.threads(), extras.torch_threads()
    kernel_threads.set_threads(n)
    try:
        yield
    finally:
        kernel_threads.set_threads(before)
        extras.set_torch_threads(torch_before)


def each_count(fn) -> list:
    """``fn()`` under every thread count of :data:`COUNTS`."""
    out = []
    for n in COUNTS:
        with threads(n):
            out.append(fn())
    return out


def assert_all_equal(results: list) -> None:
    """Every result (an array or a tuple of arrays) bit-equal to the first."""
    first = results[0] if isinstance(results[0], tuple) else (results[0],)
    for other in results[1:]:
        other = other if isinstance(other, tuple) else (other,)
        assert len(other) == len(first)
        for a, b in zip(first, other):
            assert np.array_equal(a, b)


# ----------------------------------------------------------------------------- split
@pytest.mark.parametrize("n_items, n", [(10, 3), (3, 4), (7, 1), (0, 2), (16, 4)])
def test_chunks_are_contiguous_and_even(n_items: int, n: int) -> None:
    ranges = kernel_threads.chunks(n_items, n)
    assert ranges[0][0] == 0 and ranges[-1][1] == n_items
    assert all(a[1] == b[0] for a, b in zip(ranges, ranges[1:]))
    sizes = [b - a for a, b in ranges]
    assert len(ranges) == max(1, min(n, n_items)) and max(sizes) - min(sizes) <= 1


def test_split_runs_ranges_on_the_pool_and_returns_them_in_order() -> None:
    names: dict[tuple[int, int], str] = {}
    first_two = threading.Barrier(2, timeout=30)  # the first two ranges wait for each other: two threads

    def fn(lo: int, hi: int) -> list[int]:
        if lo < 4:
            first_two.wait()
        names[(lo, hi)] = threading.current_thread().name
        return list(range(lo, hi))

    parts = kernel_threads.split(fn, 17, n=2, pieces=4)
    assert [x for p in parts for x in p] == list(range(17))
    assert [len(p) for p in parts] == [3, 2, 2, 2, 2, 2, 2, 2]  # contiguous, sizes within one
    ran_on = {names[(0, 3)], names[(3, 5)]}
    assert len(ran_on) == 2 and threading.current_thread().name in ran_on
    assert {name for name in names.values()} <= ran_on  # n threads: the caller and one of the pool's


def test_split_calls_once_with_one_thread_few_items_or_from_a_worker() -> None:
    calls: list[tuple[int, int]] = []

    def fn(lo: int, hi: int) -> None:
        calls.append((lo, hi))

    kernel_threads.split(fn, 50, n=1)
    kernel_threads.split(fn, kernel_threads.MIN_ITEMS - 1, n=4)
    assert calls == [(0, 50), (0, kernel_threads.MIN_ITEMS - 1)]

    def outer(lo: int, hi: int) -> list:  # a split inside a pool thread stays on that thread
        return kernel_threads.split(lambda a, b: threading.current_thread().name, 8, n=2)

    inner = kernel_threads.split(outer, 8, n=2)
    assert len(inner[1]) == 1 and inner[1][0].startswith("catpose-kernel")


def test_split_raises_a_ranges_error_after_all_ranges_ran() -> None:
    done: list[int] = []

    def fn(lo: int, hi: int) -> None:
        if lo > 0:
            raise ValueError(f"range {lo}")
        done.append(lo)

    with pytest.raises(ValueError, match="range"):
        kernel_threads.split(fn, 9, n=3)
    assert done == [0]


def test_the_threads_key_sets_the_kernels_and_torchs_counts() -> None:
    with threads(2):
        assert kernel_threads.threads() == 2
        assert extras.torch_threads() in (None, 2)  # None: torch not installed
    with threads(None):
        assert kernel_threads.threads() == 1  # null: the kernels take 1, torch keeps its own
    for bad in (0, -1, 1.5, 2.0, True, "two", "2"):
        with pytest.raises(ValueError, match="auto or an integer at least 1"):
            kernel_threads.set_threads(bad)


def test_auto_takes_omp_num_threads_else_the_cpus_this_process_may_use(monkeypatch) -> None:
    cpus = len(os.sched_getaffinity(0))
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    assert kernel_threads.available() == min(cpus, kernel_threads.MAX_AUTO)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")  # a joblib or Ray worker's share
    assert kernel_threads.available() == 3
    assert kernel_threads.resolve("auto") == kernel_threads.resolve(" AUTO ") == 3
    monkeypatch.setenv("OMP_NUM_THREADS", "1000")
    assert kernel_threads.available() == kernel_threads.MAX_AUTO
    for ignored in ("0", "", "four", "2,1"):  # not a positive count: the affinity decides
        monkeypatch.setenv("OMP_NUM_THREADS", ignored)
        assert kernel_threads.available() == min(cpus, kernel_threads.MAX_AUTO)
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    with threads("auto"):
        assert kernel_threads.threads() == 2
        assert extras.torch_threads() in (None, 2)


def test_the_default_is_auto_for_runs_and_for_the_python_api(monkeypatch, repo_root) -> None:
    import yaml

    assert yaml.safe_load((repo_root / "configs" / "run.yaml").read_text())["threads"] == kernel_threads.AUTO
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    monkeypatch.setattr(kernel_threads, "_threads", None)  # a process where no run has set the key
    assert kernel_threads.threads() == 3


# ----------------------------------------------------------------------------- the kernels
def _box(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A box cloud with a bump (no sliding symmetry), its normals, and a moved subset of it."""
    rng = np.random.default_rng(seed)
    tgt, normals = box_cloud((0.8, 0.5, 0.3), (0.0, 0.0, 0.0), 3000, rng)
    tgt[(tgt[:, 2] > 0.14) & (tgt[:, 0] > 0.2), 2] += 0.05
    T_gt = make_T(Rotation.from_rotvec([0.05, -0.03, 0.3]).as_matrix(), [0.04, -0.02, 0.0])
    return tgt, normals, (tgt[::5] - T_gt[:3, 3]) @ T_gt[:3, :3]


def _starts(seed: int, count: int, scale: float) -> np.ndarray:
    """``count`` start poses, small random turns and shifts of up to ``scale`` rad / units."""
    rng = np.random.default_rng(seed)
    return np.stack(
        [
            make_T(Rotation.from_rotvec(rng.normal(size=3) * scale).as_matrix(), rng.normal(size=3) * scale / 3)
            for _ in range(count)
        ]
    )


def test_point_to_plane_icp_is_the_same_on_any_number_of_threads() -> None:
    from catpose.point_to_plane_kernel import refine_many

    tgt, normals, src = _box(1)
    grid = cell_grid.build(tgt, 0.1)
    starts = _starts(2, 11, 0.4)
    results = each_count(lambda: refine_many(src, grid, normals, starts, 0.1, 15, return_steps=True))
    assert_all_equal(results)
    assert len(set(results[0][1])) > 1  # starts stop after different numbers of steps


def test_yaw_icp_is_the_same_on_any_number_of_threads() -> None:
    from catpose.yaw_icp_kernel import refine_yaw_many

    tgt, normals, src = _box(3)
    grid = cell_grid.build(tgt, 0.1)
    starts = _starts(4, 9, 0.3)
    axes = np.einsum("bij,j->bi", starts[:, :3, :3], [0.0, 0.0, 1.0])
    results = each_count(lambda: refine_yaw_many(src, grid, normals, starts, axes, 0.1, 15))
    assert_all_equal(results)
    assert not np.allclose(results[0], starts)


def test_irls_kernel_is_the_same_on_any_number_of_threads() -> None:
    from catpose.methods.ours import irls

    rng = np.random.default_rng(5)
    m, n = 10, 12
    p = rng.normal(size=(n, 3)) * 0.4
    q = p[None].repeat(2, axis=1) @ Rotation.random(m, random_state=rng).as_matrix().transpose(0, 2, 1)
    q = q + rng.normal(size=q.shape) * 0.05
    A = rng.random((m, n, 2 * n))
    A /= A.sum(2, keepdims=True)
    T0 = np.tile(np.eye(4), (m, 1, 1))
    results = each_count(lambda: irls.solve_numpy(p, q, A, T0, ("pose", "joint"), compiled=True))
    assert_all_equal(results)
    assert len(set(results[0][3])) > 1  # candidates stop after different numbers of iterations


def test_chamfer_distances_are_the_same_on_any_number_of_threads() -> None:
    from catpose.methods.ours.point_choice import chamfer_distances

    tgt, _, src = _box(6)
    tree = cKDTree(tgt)
    starts = _starts(7, 13, 0.5)
    results = each_count(lambda: chamfer_distances(tree, src, starts))
    assert_all_equal(results)
    one = [chamfer_distances(tree, src, starts[b : b + 1])[0] for b in range(len(starts))]
    np.testing.assert_allclose(results[0], one, rtol=1e-12)  # each pose's distance on its own
    # the grid answers the points within its reach, the tree the rest: the tree's bits, any count
    grid = cell_grid.build(tgt, 0.1, 2)
    with_grid = each_count(lambda: chamfer_distances(tree, src, starts, grid))
    assert_all_equal(with_grid)
    np.testing.assert_array_equal(with_grid[0], results[0])
    moved = np.einsum("bij,nj->bni", starts[:, :3, :3], src) + starts[:, None, :3, 3]
    near = tree.query(moved.reshape(-1, 3))[0]
    assert 0.1 < (near <= 0.1).mean() < 0.9  # both searches answer some of the points


def test_visibility_scores_are_the_same_on_any_number_of_threads() -> None:
    from catpose.methods.pose_scores_kernel import visibility_scores

    tgt, normals, src = _box(8)
    poses = _starts(9, 10, 0.2)  # near the pose that maps src onto the box: scores below the truncation
    in_grid, tpl_grid = cell_grid.build(src, 0.1), cell_grid.build(tgt, 0.1)
    results = each_count(lambda: visibility_scores(src, in_grid, poses, tpl_grid, normals, 0.1))
    assert_all_equal(results)
    assert len(set(results[0])) == len(poses)


# ----------------------------------------------------------------------------- ours
@pytest.mark.usefixtures("private_cache_dir")
def test_ours_gives_the_same_poses_on_one_and_two_threads() -> None:
    """Ours as configured (``configs/method/ours.yaml``) on a depth frame (the resting grid: yaw
    and full ICP, Chamfer beam) and on a bare partial cloud."""
    from _ours_fixtures import chair_template, partial_problem
    from test_ours_depth import scene_problem

    from catpose.bench.perf.registration import _seeded, build_method

    template = chair_template()
    problems = [scene_problem(template, 1)[0], scene_problem(template, 2, up_object=(1.0, 0.0, 0.0))[0]]
    problems.append(partial_problem(template, 3)[0])
    method = build_method("ours", 0)

    def register_all() -> list:
        out = []
        for p in problems:
            _seeded(0, p.sample_id)  # as bench run seeds every call
            out.append(method.register(p))
        return out

    answers = []
    for n in (1, 2):
        with threads(n):
            answers.append(register_all())
    for one, two in zip(*answers):
        assert np.array_equal(one.T_template_camera, two.T_template_camera)
        assert np.array_equal(one.candidates_T, two.candidates_T)
        assert np.array_equal(one.candidate_scores, two.candidate_scores)
