"""Ours with the coarse search's translation start at the points' median instead of their centroid:
one JSON line per sample and variant (study: README.md).

    python experiments/robust_start/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [OVERRIDE ...]
    python experiments/robust_start/run.py --bench VARIANT BENCH_ARG ...   # `bench` with the variant installed

Each ``VARIANT`` is a name of :data:`VARIANTS` (``default``: ours unchanged); each problem is loaded
once and registered by every variant in turn, into ``OUT_DIR/<variant>.jsonl``
(``experiments/_lib/patched_runs.py``, as ``bench run`` builds and seeds them). ``median start``
replaces, in this process only, :func:`catpose.methods.ours.rest_search.grid_poses` by
:func:`median_grid_poses`; everything else in the product is unchanged. ``--bench`` runs the
``bench`` command line (``bench run ...``) with the variant installed (the category templates).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

VARIANTS = ("default", "median start")
ORIGINAL: dict = {}


def median_grid_poses(
    ups, ground_normal_camera, points_camera, template_points, template_normals, yaws, symmetry_axis=None, shift=0.0
):
    """:func:`catpose.methods.ours.rest_search.grid_poses` with medians for centroids: each pose
    puts the per-axis median (in the pose's camera axes) of the template's camera-facing points on
    the per-axis median of ``points_camera`` plus the pose's move along the ground, where ours puts
    their means on each other: ``t = R (c - (m + move))``, ``c`` the facing points' median of the
    rows ``R^T p``, ``m`` the points' median (ours: ``t = mean(p) - R (mean + move)``, the same
    equation with means, since ``R mean(R^T p) = mean(p)``). The rotations, moves and facing test
    are ours' (the view direction from ``m``)."""
    from catpose.geometry import norm3
    from catpose.methods.ours import rest_search

    R, rest = rest_search.grid_rotations(ups, ground_normal_camera, yaws, symmetry_axis)
    moves = None
    if shift > 0.0 and yaws > 1:
        R, rest, moves = rest_search._shifted(  # ours' moves along the ground, unchanged
            R, rest, np.asarray(ups, dtype=np.float64), ground_normal_camera, template_points, yaws, shift
        )
    m = np.median(np.asarray(points_camera, dtype=np.float64), axis=0)
    view = -m / max(norm3(m), 1e-12)  # towards the camera, camera frame
    P = np.asarray(template_points, dtype=np.float64)
    v = np.einsum("bij,j->bi", R, view)  # towards the camera, template frame, per pose
    facing = np.einsum("mj,bj->mb", np.asarray(template_normals, dtype=np.float64), v) > 0.0
    T = np.tile(np.eye(4), (len(R), 1, 1))
    T[:, :3, :3] = R
    for b in range(len(R)):
        Pf = P[facing[:, b]] if facing[:, b].any() else P
        c = np.median(np.einsum("mi,ij->mj", Pf, R[b]), axis=0)  # rows R^T p: the pose's camera axes
        T[b, :3, 3] = np.einsum("ij,j->i", R[b], c - (m if moves is None else m + moves[b]))
    return T, rest


def install(variant: str) -> None:
    """Install ``variant``'s placement (``default``: ours' own) in this process."""
    from catpose.methods.ours import rest_search

    ORIGINAL.setdefault("grid_poses", rest_search.grid_poses)
    rest_search.grid_poses = median_grid_poses if variant == "median start" else ORIGINAL["grid_poses"]


if __name__ == "__main__":
    from patched_runs import main

    sys.exit(main(sys.argv[1:], {v: (lambda v=v: install(v)) for v in VARIANTS}))
