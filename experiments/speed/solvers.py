"""Seconds per solve of the TEASER-style solver (``method=teaser``) and of TEASER++ itself
(``method=teaserpp``, when ``teaserpp_python`` is importable) on the same synthetic
correspondence sets, with outlier rates from 0.5 to 0.99.

Each problem: ``n`` correspondences of points drawn uniformly in the unit ball (object-normalised
units), a random pose, inliers ``b_i = R a_i + t + e_i`` with ``|e_i| <= noise_bound``, outliers
drawn uniformly in the transformed ball. At ``n = 1000`` and rate 0.5 the max clique has about
500 points. Both solvers get identical inputs and arguments; times are wall seconds of one solve
(ours: :func:`catpose.methods.teaser_solver.solve`, after one untimed call that compiles the
numba kernels; TEASER++: its ``solve``, run with ``OMP_NUM_THREADS`` as set by the caller).

Usage::

    python experiments/speed/solvers.py                 # 50 problems, n = 1000
    python experiments/speed/solvers.py --problems 10 --n 500
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CorrespondenceProblem:
    """Matched points ``dst ~ R_gt src + t_gt`` with known inliers.

    Attributes:
        src, dst: (N, 3) row-matched points (object-normalised).
        R_gt: (3, 3); t_gt: (3,).
        inliers: indices of the true inliers.
        outlier_rate: fraction of outliers.
        noise_bound: inlier bound used to generate (and to solve).
    """

    src: np.ndarray
    dst: np.ndarray
    R_gt: np.ndarray
    t_gt: np.ndarray
    inliers: np.ndarray
    outlier_rate: float
    noise_bound: float


def _in_ball(rng: np.random.Generator, k: int) -> np.ndarray:
    x = rng.normal(size=(k, 3))
    return x / np.linalg.norm(x, axis=1, keepdims=True) * rng.uniform(0, 1, (k, 1)) ** (1 / 3)


def synthetic_problem(
    seed: int, outlier_rate: float, n: int = 1000, noise_bound: float = 0.05
) -> CorrespondenceProblem:
    """One correspondence set (see the module docstring); deterministic in ``seed``."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    R = Rotation.random(random_state=rng).as_matrix()
    t = rng.uniform(-0.5, 0.5, 3)
    n_in = int(round((1.0 - outlier_rate) * n))
    src = _in_ball(rng, n)
    dst = src @ R.T + t
    e = rng.normal(size=(n_in, 3))
    e *= (rng.uniform(0, noise_bound, n_in) / np.linalg.norm(e, axis=1))[:, None]
    dst[:n_in] += e
    dst[n_in:] = _in_ball(rng, n - n_in) @ R.T + t
    perm = rng.permutation(n)
    return CorrespondenceProblem(
        src[perm], dst[perm], R, t, np.sort(np.argsort(perm)[:n_in]), float(outlier_rate), float(noise_bound)
    )


def problem_set(
    problems: int = 50, n: int = 1000, noise_bound: float = 0.05, seed: int = 0
) -> list[CorrespondenceProblem]:
    """``problems`` sets with outlier rates evenly spaced over [0.5, 0.99]."""
    rates = np.linspace(0.5, 0.99, problems)
    return [synthetic_problem(seed + i, float(r), n, noise_bound) for i, r in enumerate(rates)]


def _angle_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R_a.T @ R_b) - 1) / 2, -1, 1))))


def teaserpp_available() -> bool:
    try:
        import teaserpp_python  # noqa: F401
    except ImportError:
        return False
    return True


def measure(problems: list[CorrespondenceProblem], with_teaserpp: bool | None = None) -> list[dict]:
    """One row per problem: outlier rate, clique sizes and solve seconds of both solvers, and
    whether they chose the same clique (then the rotation gap in degrees). TEASER++'s clique is
    counted as it returns it (its PMC exact solver has been seen to list a vertex twice).

    Args:
        problems: the correspondence sets.
        with_teaserpp: also time TEASER++ (None: when importable).
    """
    from catpose.methods import teaser_solver

    if with_teaserpp is None:
        with_teaserpp = teaserpp_available()
    if problems:  # compile (or load from numba's cache) outside the timings
        teaser_solver.solve(problems[0].src[:50], problems[0].dst[:50], problems[0].noise_bound)
    rows = []
    for i, p in enumerate(problems):
        t0 = time.perf_counter()
        ours = teaser_solver.solve(p.src, p.dst, p.noise_bound)
        row = {
            "problem": i,
            "outlier_rate": p.outlier_rate,
            "inliers": len(p.inliers),
            "clique_ours": len(ours.clique),
            "exact_ours": ours.clique_exact,
            "seconds_ours": time.perf_counter() - t0,
        }
        if with_teaserpp:
            from catpose.methods import teaser

            t0 = time.perf_counter()
            tpp = teaser.solve_teaserpp(p.src, p.dst, p.noise_bound, min_clique_size=0)
            seconds = time.perf_counter() - t0
            same = np.array_equal(ours.clique, tpp.clique)
            row.update(
                clique_teaserpp=len(tpp.clique),
                seconds_teaserpp=seconds,
                same_clique=same,
                rotation_gap_deg=_angle_deg(ours.R, tpp.R) if same else float("nan"),
            )
        rows.append(row)
    return rows


def summary(rows: list[dict], min_clique: int = 400) -> list[dict]:
    """Median and max seconds per solver over all rows and over the rows whose clique (ours) has
    at least ``min_clique`` points (the large-clique class)."""
    out = []
    for label, sel in (("all", rows), (f"clique >= {min_clique}", [r for r in rows if r["clique_ours"] >= min_clique])):
        if not sel:
            continue
        entry = {"problems": label, "count": len(sel)}
        if "same_clique" in sel[0]:
            entry["same_clique"] = sum(r["same_clique"] for r in sel)
            entry["same_clique_size"] = sum(r["clique_ours"] == r["clique_teaserpp"] for r in sel)
        for key in ("seconds_ours", "seconds_teaserpp"):
            if key in sel[0]:
                xs = [r[key] for r in sel]
                entry[f"median_{key}"], entry[f"max_{key}"] = statistics.median(xs), max(xs)
        out.append(entry)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python experiments/speed/solvers.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--problems", type=int, default=50, help="number of problems (default 50)")
    ap.add_argument("--n", type=int, default=1000, help="correspondences per problem (default 1000)")
    ap.add_argument("--noise-bound", type=float, default=0.05, help="object-normalised (default 0.05)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-teaserpp", action="store_true", help="time only the TEASER-style solver")
    args = ap.parse_args(argv)
    from tabulate import tabulate

    rows = measure(problem_set(args.problems, args.n, args.noise_bound, args.seed), False if args.no_teaserpp else None)
    print(tabulate(rows, headers="keys", floatfmt=".4g"))
    print()
    print(tabulate(summary(rows), headers="keys", floatfmt=".4g"))
    if not args.no_teaserpp and "seconds_teaserpp" not in rows[0]:
        print("\nTEASER++ (teaserpp_python) is not importable: only the TEASER-style solver was timed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
