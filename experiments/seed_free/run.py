"""Ours with its coarse search (and, for one variant, the dictionary pool's prescreen) on points no
seed draws: one JSON line per sample and variant (study: README.md).

    python experiments/seed_free/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [OVERRIDE ...]

Each ``VARIANT`` is a name of :data:`VARIANTS` (``default``: ours unchanged); each problem is loaded
once and registered by every variant in turn, into ``OUT_DIR/<variant>.jsonl``. A variant replaces,
in this process only, the inputs of ours' coarse search
(:func:`catpose.methods.ours.rest_search.search`) and, for ``pool on fixed points``, of the
dictionary pool's Chamfer prescreen (:func:`catpose.methods.ours.choice.dictionary_pool`); the
functions themselves and everything else in the product are unchanged.

The fixed points (:func:`fixed_points`), the same under every seed for a given mask:

- observed: the mask's pixels with depth on the lattice of ours' last comparisons
  (``depth_final_pixels``; :func:`catpose.methods.ours.refine.final_inputs`, back-projected,
  camera frame, the depth unit), ordered by farthest-point sampling from the first lattice pixel
  (raster order); the head of :data:`CHAMFER_POINTS` replaces ``cands.chamfer_src`` (its own
  head of ``FIRST_POINTS`` is then a spread subset, as the search wants), and all of them replace
  ``problem.points_camera`` in the placement (their centroid);
- template: :func:`catpose.methods.ours.refine.mesh_sample` (a fixed area-weighted sample of the
  mesh and its triangles' normals) replaces ``template.points`` / ``normals`` (the ICP's grid, the
  placement's camera-facing front) and the features' KD-tree and Chamfer grid (the beam's and the
  prescreen's one-directional Chamfer distances).

``OVERRIDE``s are ``bench run``'s; problems are built and ours is seeded per sample as ``bench run``
does (``experiments/_lib/sample_rows.py``), so ``default`` gives the run's answers. Each line: the
answer's error, found@10's best error over ours' held poses, seconds, the answer relative to the
truth (``T_rel``, with the truth's symmetries: the seeds' agreement), and for the fixed variants
the sizes of ``cands.chamfer_src`` and of the fixed observed points and how far each lies from
the other (median nearest-neighbour distance, the depth unit: the same frame and unit).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

#: name -> (the coarse search on the fixed points, the dictionary pool's prescreen too, the
#: choice's step 2 refinement too)
VARIANTS = {
    "default": (False, False, False),
    "search on fixed points": (True, False, False),
    "pool on fixed points": (True, True, False),
    "step 2 on fixed points": (True, True, True),
}
#: observed fixed points that replace ``cands.chamfer_src`` (its size: hypotheses.CHAMFER_POINTS)
CHAMFER_POINTS = 256

ORIGINAL: dict = {}
STATE: dict = {"sel": None, "last": (None, None), "info": {}}


class _MeshTemplate:
    """What the coarse search reads of a template (id, points, normals, symmetry axis), with the
    fixed mesh sample as its points (a class, not a namespace: the hash memo holds weak references)."""

    def __init__(self, template, points: np.ndarray, normals: np.ndarray) -> None:
        self.template_id = template.template_id + "#mesh_sample"
        self.points, self.normals = points, normals
        self.symmetry_axis = template.symmetry_axis


class _SearchProblem:
    """What the coarse search reads of a problem, with the fixed points."""

    def __init__(self, problem, template, points: np.ndarray) -> None:
        self.template, self.points_camera = template, points
        self.ground_normal_camera = problem.ground_normal_camera


_MESH: dict = {}


def mesh_side(template, feats):
    """(template stand-in, features) of the fixed mesh sample, cached per mesh."""
    from scipy.spatial import cKDTree

    from catpose import cell_grid
    from catpose.content_hash import template_hash
    from catpose.methods.ours.hypotheses import CHAMFER_REACH
    from catpose.methods.ours.point_choice import VISIBILITY_TRUNC
    from catpose.methods.ours.refine import mesh_sample

    key = template_hash(template, "vertices", "triangles")
    hit = _MESH.get(key)
    if hit is None:
        grid, normals = mesh_sample(template)
        P = np.ascontiguousarray(grid.points, dtype=np.float64)
        reach = max(VISIBILITY_TRUNC, CHAMFER_REACH)
        hit = _MESH[key] = (
            _MeshTemplate(template, P, normals),
            cKDTree(P),
            cell_grid.build(P, reach, cell_grid.CACHED_CELLS_PER_REACH),
        )
    tpl, tree, truncated = hit
    return tpl, replace(feats, tree=tree, truncated=truncated)


def fixed_points(problem) -> np.ndarray:
    """The observed fixed points (N, 3) of ``problem`` in farthest-point order (module docstring),
    cached for the last problem."""
    from catpose.methods.keypoints import farthest_point_indices
    from catpose.methods.ours.check import final_verifier
    from catpose.methods.ours.refine import final_inputs

    last, pts = STATE["last"]
    if last is problem:
        return pts
    from catpose.methods.ours.span import in_span, median_depth

    points = final_inputs(final_verifier(STATE["sel"], problem), problem.template)[0]
    points = points[in_span(points[:, 2], median_depth(problem.depth_image))]  # ours' depth span
    pts = np.ascontiguousarray(points[farthest_point_indices(points, len(points))])
    STATE["last"] = (problem, pts)
    return pts


def search(problem, ups, cands, feats, verifier, rs, timings):
    """:func:`catpose.methods.ours.rest_search.search` on the fixed points."""
    from scipy.spatial import cKDTree

    pts = fixed_points(problem)
    tpl, mesh_feats = mesh_side(problem.template, feats)
    src = cands.chamfer_src
    STATE["info"] = {
        "n_chamfer_src": int(len(src)),
        "n_fixed": int(len(pts)),
        "chamfer_src_to_fixed": float(np.median(cKDTree(pts).query(src)[0])),
        "fixed_to_chamfer_src": float(np.median(cKDTree(src).query(pts)[0])),
        "chamfer_src_spacing": float(np.median(cKDTree(src).query(src, k=2)[0][:, 1])),
    }
    fixed = replace(cands, chamfer_src=pts[:CHAMFER_POINTS])
    return ORIGINAL["search"](_SearchProblem(problem, tpl, pts), ups, fixed, mesh_feats, verifier, rs, timings)


def dictionary_pool(sel, problem, cands, feats, up):
    """:func:`catpose.methods.ours.choice.dictionary_pool` with its prescreen on the fixed points."""
    _, mesh_feats = mesh_side(problem.template, feats)
    fixed = replace(cands, chamfer_src=fixed_points(problem)[:CHAMFER_POINTS])
    return ORIGINAL["pool"](sel, problem, fixed, mesh_feats, up)


def select_by_depth(sel, problem, pool, cands, feats, ups, timings, verifier):
    """:func:`catpose.methods.ours.choice.select_by_depth` with its step 2 (the depth_top_k poses
    refined by ICP) on the fixed points against the mesh sample (its grid of reach
    ``REFINE_MAX_DISTANCE`` and its normals) instead of ``cands.chamfer_src`` and the template's
    points; steps 3 and 4 read the same points as ours' own."""
    from catpose.methods.ours.refine import mesh_sample

    pts = fixed_points(problem)
    grid, normals = mesh_sample(problem.template)
    key = id(problem.template)
    tpl = _TEMPLATES.get(key)
    if tpl is None or tpl[0] is not problem.template:
        tpl = _TEMPLATES[key] = (problem.template, replace(problem.template, points=grid.points, normals=normals))
    fixed = replace(cands, chamfer_src=pts[:CHAMFER_POINTS])
    moved = replace(problem, template=tpl[1])
    return ORIGINAL["select"](sel, moved, pool, fixed, replace(feats, pairing=grid), ups, timings, verifier)


_TEMPLATES: dict = {}


def use(variant: str) -> None:
    """Install ``variant``'s search and pool in ours (for the whole process until the next call)."""
    from catpose.methods.ours import choice, rest_search

    ORIGINAL.setdefault("search", rest_search.search)
    ORIGINAL.setdefault("pool", choice.dictionary_pool)
    ORIGINAL.setdefault("select", choice.select_by_depth)
    on_search, on_pool, on_select = VARIANTS[variant]
    rest_search.search = search if on_search else ORIGINAL["search"]
    choice.dictionary_pool = dictionary_pool if on_pool else ORIGINAL["pool"]
    choice.select_by_depth = select_by_depth if on_select else ORIGINAL["select"]
    STATE["info"] = {}


def main(argv: list[str]) -> int:
    from sample_rows import build, variant_rows

    out_dir, seed, names = Path(argv[0]), int(argv[1]), argv[2].split(",")
    unknown = [v for v in names if v not in VARIANTS]
    if unknown:
        raise SystemExit(f"{unknown}: not in VARIANTS ({', '.join(VARIANTS)})")
    _, method, dataset, protocol = build(seed, argv[3:])
    STATE["sel"] = method.selection

    def method_for(v: str):
        use(v)
        return method

    variant_rows(out_dir, seed, names, dataset, protocol, method_for, warm_each=True, extra=lambda: STATE["info"])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
