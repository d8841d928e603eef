"""TEASER++ itself (MIT-SPARK/TEASER-plusplus) through its Python bindings ``teaserpp_python``.

catpose does not build or ship TEASER++: where ``teaserpp_python`` is not importable,
constructing this method raises :class:`~catpose.errors.ConfigError` pointing to TEASER++'s own
build instructions (its README, "Minimal Python 3 example", and teaser.readthedocs.io).
``method=teaser`` is the re-implementation (:mod:`catpose.methods.teaser_solver`) of the same
pipeline, with the same arguments.

The arguments mean the same for both solvers:

- ``noise_bound`` (object-normalised) is passed unchanged; both use ``2 noise_bound sqrt(cbar2)``
  for pairwise consistency and ``2 noise_bound`` as the rotation (TIM) bound.
- ``cost_threshold`` is unit-free in ``method=teaser`` (a change of the GNC cost in units of the
  squared TIM bound ``cbar2 (2 noise_bound)^2``); TEASER++ compares the absolute change of
  ``sum_k w_k r_k^2``. It is converted: ``rotation_cost_threshold = cost_threshold * cbar2 *
  (2 noise_bound)^2``. (Passing 1e-6 unconverted lets TEASER++ stop while the GNC weights are
  still fractional when the points are small, as they are here.)
- the exact max clique (``PMC_EXACT``), ``gnc_factor``, ``max_iterations``, the TIM graph.

A max clique of 0 or 1 correspondences gives no pose in TEASER++ itself
(``RobustRegistrationSolver::solve`` sets ``solution_.valid = false``; the pose it still returns
is unset and changes from run to run): :func:`solve` raises
:class:`~catpose.errors.InvalidInputError` then, as ``method=teaser`` does
(:data:`~catpose.methods.teaser_solver.MIN_CLIQUE_SIZE`). Such a target gives no candidate; with
dictionary matching the other partial templates still can, and a sample with no candidate at
all is recorded as failed with that reason instead of scoring a meaningless pose.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from catpose.errors import ConfigError, InvalidInputError
from catpose.methods.correspondence import PIPELINE_SPEC
from catpose.methods.registry import register_method
from catpose.methods.teaser import TEASER
from catpose.methods.teaser_solver import MIN_CLIQUE_SIZE, SolverResult, checked_inputs

_MISSING = (
    "method=teaserpp needs the teaserpp_python module (TEASER++'s Python bindings), which is not "
    "importable: build and install it into this environment as TEASER++'s own README says "
    "(github.com/MIT-SPARK/TEASER-plusplus, 'Minimal Python 3 example'; it builds on Python 3.11 too), "
    "or use method=teaser"
)


def _import_teaserpp():
    try:
        import teaserpp_python
    except ImportError:
        raise ConfigError(_MISSING) from None
    return teaserpp_python


@contextlib.contextmanager
def _stdout_silenced() -> Iterator[None]:
    """Send file descriptor 1 to /dev/null: TEASER++ built with TEASER_DIAG_PRINT writes its
    progress to the C++ stdout, which would interleave with the runner's output."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def solve(
    src: np.ndarray,
    dst: np.ndarray,
    noise_bound: float,
    cbar2: float = 1.0,
    gnc_factor: float = 1.4,
    max_iterations: int = 100,
    cost_threshold: float = 1e-6,
    rotation_tim_graph: str = "chain",
    min_clique_size: int = MIN_CLIQUE_SIZE,
) -> SolverResult:
    """``dst ~ R src + t`` by TEASER++ (scale fixed, exact max clique, GNC-TLS rotation), with
    the arguments of :func:`catpose.methods.teaser_solver.solve` (see the module docstring).

    Args:
        src, dst: (N, 3) row-matched points (object-normalised).
        noise_bound: inlier bound ``beta`` (same unit).
        min_clique_size: a max clique smaller than this raises :class:`InvalidInputError`
            (0 returns TEASER++'s raw output, whatever its clique).

    Returns:
        :class:`~catpose.methods.teaser_solver.SolverResult`; ``gnc_iterations`` is -1 (TEASER++
        does not report it), ``timings["solve_s"]`` the wall time of TEASER++'s ``solve``.
    """
    tpp = _import_teaserpp()
    src, dst = checked_inputs(src, dst, noise_bound, rotation_tim_graph, "TEASER++")
    Solver = tpp.RobustRegistrationSolver
    params = Solver.Params()
    params.noise_bound = float(noise_bound)
    params.cbar2 = float(cbar2)
    params.estimate_scaling = False
    params.rotation_estimation_algorithm = Solver.ROTATION_ESTIMATION_ALGORITHM.GNC_TLS
    params.rotation_gnc_factor = float(gnc_factor)
    params.rotation_max_iterations = int(max_iterations)
    params.rotation_cost_threshold = float(cost_threshold) * float(cbar2) * (2.0 * float(noise_bound)) ** 2
    graphs = Solver.INLIER_GRAPH_FORMULATION
    params.rotation_tim_graph = graphs.CHAIN if rotation_tim_graph == "chain" else graphs.COMPLETE
    params.inlier_selection_mode = Solver.INLIER_SELECTION_MODE.PMC_EXACT
    solver = Solver(params)
    with _stdout_silenced():
        t0 = time.perf_counter()
        solver.solve(np.ascontiguousarray(src.T), np.ascontiguousarray(dst.T))
        solve_s = time.perf_counter() - t0
    clique = np.sort(np.asarray(solver.getInlierMaxClique(), dtype=np.int64))  # as returned (may repeat)
    sol = solver.getSolution()
    if len(np.unique(clique)) < min_clique_size or (min_clique_size and not sol.valid):
        raise InvalidInputError(
            f"TEASER++ max clique has {len(np.unique(clique))} of {len(src)} correspondences: degenerate, "
            f"no valid solution under {min_clique_size} (registration.cc, RobustRegistrationSolver::solve)"
        )
    R = np.asarray(sol.rotation, dtype=np.float64).reshape(3, 3)
    t = np.asarray(sol.translation, dtype=np.float64).reshape(3)
    translation_inliers = np.asarray(solver.getTranslationInliers(), dtype=np.int64)
    return SolverResult(
        R,
        t,
        clique,
        True,
        np.asarray(solver.getRotationInliersMask(), dtype=bool).reshape(-1),
        clique[translation_inliers[translation_inliers < len(clique)]],
        -1,
        {"solve_s": solve_s},
    )


# not in bench suite: TEASER++ is built by hand (method=teaser is its re-implementation there)
@register_method("teaserpp", "Teaser++", suite=(), requires="teaserpp_python", **PIPELINE_SPEC)
class TEASERPlusPlus(TEASER):
    """The same pipeline and arguments as :class:`~catpose.methods.teaser.TEASER`, solved by
    ``teaserpp_python.RobustRegistrationSolver`` through :func:`solve`."""

    solver_name = "teaserpp"

    def __init__(self, **kwargs: Any) -> None:
        _import_teaserpp()  # how to build TEASER++ when it is absent, before any sample runs
        super().__init__(**kwargs)

    def _solve(self, src: np.ndarray, dst: np.ndarray, seed: int) -> SolverResult:
        """By TEASER++ (:func:`solve`; its max clique search is exact and draws no random numbers)."""
        return solve(
            src,
            dst,
            self.noise_bound,
            self.cbar2,
            self.gnc_factor,
            self.max_iterations,
            self.cost_threshold,
            self.rotation_tim_graph,
        )
