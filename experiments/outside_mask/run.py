"""Ours with the observed depth just outside the object's mask read as evidence: one JSON line per
sample (study: README.md).

    python experiments/outside_mask/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [OVERRIDE ...]

Each ``VARIANT`` is a name of :data:`VARIANTS` (``default``: ours unchanged); each problem is loaded
once and registered by every variant in turn, into ``OUT_DIR/<variant>.jsonl``. A variant replaces,
in this process only, ours' depth check (:meth:`catpose.methods.ours.check.DepthVerifier.scores`, every
stage that ranks poses by it) and, for ``+refine`` variants, the points of the last comparisons'
refinement (:func:`catpose.methods.ours.choice.final_inputs`); nothing in the product changes.
``OVERRIDE``s are ``bench run``'s; the problems are built and ours is seeded per sample as
``bench run`` does (``experiments/_lib/sample_rows.py``), so ``default`` gives the
run's answers. Each line: the answer's error, found@10's best error over ours' held poses, and
ours' seconds for the sample (the variants run back to back, so their seconds pair up). Finished
samples already in a variant's file are skipped.

The ring: the image pixels at most ``k`` pixels outside the mask (3 x 3 dilations). The
segmenter's eroded edge (``experiments/depth_check_masks``: the component of dirty masks that
misleads ours) moves the object's rim and a mug's handle into it.

- ``ring K``: on the check's lattice, a ring pixel that a pose renders and whose observed depth lies
  within ``tau`` of the rendering is evidence for the pose: it takes ``W (1 - |r - o| / tau)`` off
  the pose's summed cost (``W`` = 1: what an explained mask pixel saves over an unexplained one).
  Ring pixels rendered in front of the observation by more than ``tau`` already cost the free-space
  weight (as everywhere outside the mask); rendered behind it, or not rendered, they cost nothing.
- ``+refine``: the last comparisons' refinement also pairs the ring's lattice pixels whose observed
  depth lies within 3 x 1.4826 MAD of the mask's median depth (pose-independent: the surface the
  eroded edge took, not the table behind it).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numba
import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

#: name -> (ring width in image pixels, evidence weight W (0: the check unchanged), refine on the
#: ring's pixels too, the check's lattices that read the ring: "all" or "final" (the last comparisons' only))
VARIANTS = {
    "default": (0, 0.0, False, "all"),
    "ring 3 px": (3, 1.0, False, "all"),
    "ring 5 px": (5, 1.0, False, "all"),
    "ring 3 px +refine": (3, 1.0, True, "all"),
    "refine ring 3 px": (3, 0.0, True, "all"),
    "ring 3 px W 0.5 +refine": (3, 0.5, True, "all"),
    "ring 3 px final only +refine": (3, 1.0, True, "final"),
}


@numba.njit(cache=True, nogil=True)
def window_cost_ring(o, m, ring, r, tau):  # pragma: no cover - compiled
    """:func:`catpose.methods.ours.check_kernel.window_cost` and the ring's
    evidence: the sum over ``ring`` pixels outside ``m`` with ``r > 0``, ``o > 0`` and
    ``|r - o| <= tau`` of ``1 - |r - o| / tau``."""
    h, w = m.shape
    vals = np.empty(h * w)
    count = 0
    free = 0
    evidence = 0.0
    for i in range(h):
        for j in range(w):
            rr = r[i, j]
            oo = o[i, j]
            if m[i, j]:
                if rr > 0:
                    d = np.abs(rr - oo)
                    vals[count] = (d if (d < tau or d != d) else tau) / tau
                else:
                    vals[count] = 1.0
                count += 1
            elif rr > 0 and oo > 0:
                if oo - rr > tau:
                    free += 1
                elif ring[i, j] and np.abs(rr - oo) <= tau:
                    evidence += 1.0 - np.abs(rr - oo) / tau
    return vals[:count], free, evidence


def ring_mask(image_mask: np.ndarray, k: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The pixels at most ``k`` image pixels outside ``image_mask`` (3 x 3 dilations), on the lattice
    ``rows`` x ``cols``."""
    grown = ndimage.binary_dilation(image_mask, np.ones((3, 3), bool), iterations=k)
    return (grown & ~image_mask)[np.ix_(rows, cols)]


def patched(variant: str) -> tuple:
    """(scores, final_inputs, final_verifier): ours' depth check, the last refinement's points and
    the last comparisons' verifier under ``variant`` (:data:`VARIANTS`; ``default``: ours' own)."""
    from catpose.methods.ours import choice
    from catpose.methods.ours.check import DepthVerifier
    from catpose.methods.ours.refine import mesh_sample

    own = (
        ORIGINAL.setdefault("scores", DepthVerifier.scores),
        ORIGINAL.setdefault("final_inputs", choice.final_inputs),
        ORIGINAL.setdefault("final_verifier", choice.final_verifier),
    )
    if variant not in VARIANTS:
        raise SystemExit(f"{variant!r}: not one of {', '.join(VARIANTS)}")
    k, weight, refine, where = VARIANTS[variant]
    if k == 0:
        return own

    def final_verifier(sel, problem, verifier=None):
        v = own[2](sel, problem, verifier)
        if v is not verifier:
            v.__dict__["_study_final"] = True
        return v

    def ring_of(self) -> np.ndarray:
        key = f"_study_ring{k}"
        ring = self.__dict__.get(key)
        if ring is None:
            L = self.lattice
            ring = self.__dict__[key] = ring_mask(np.asarray(self.image.mask, bool), k, L.rows, L.cols)
        return ring

    def scores(self, T_template_camera):
        if where == "final" and not self.__dict__.get("_study_final"):
            return own[0](self, T_template_camera)
        L, ring = self.lattice, ring_of(self)
        mask_pixels = self.mask_pixels
        n_mask = max(mask_pixels, 1)
        out = []
        for win, r in self.render(T_template_camera):
            if win is None:
                out.append(np.inf)
                continue
            costs, free, evidence = window_cost_ring(L.depth[win], L.mask[win], ring[win], r, self.tau)
            mask_cost = costs.sum() + (mask_pixels - len(costs))
            out.append((mask_cost + self.free_weight * free - weight * evidence) / n_mask)
        return np.asarray(out, dtype=np.float64)

    scores = own[0] if weight == 0 else scores
    if not refine:
        return scores, own[1], final_verifier

    def final_inputs(verifier, template):
        L, ring = verifier.lattice, ring_of(verifier)
        inside = L.depth[L.mask & (L.depth > 0)]
        med = float(np.median(inside)) if inside.size else 0.0
        mad = 1.4826 * float(np.median(np.abs(inside - med))) if inside.size else 0.0
        near = ring & (L.depth > 0) & (np.abs(L.depth - med) <= 3.0 * mad)
        keep = (L.mask & (L.depth > 0)) | near
        points = np.ascontiguousarray(L.depth[keep][:, None] * L.dirs[keep])
        return (points, *mesh_sample(template))

    return scores, final_inputs, final_verifier


ORIGINAL: dict = {}


def use(functions: tuple) -> None:
    """Install (scores, final_inputs, final_verifier) of :func:`patched` in ours, for the whole run."""
    from catpose.methods.ours import choice
    from catpose.methods.ours.check import DepthVerifier

    DepthVerifier.scores, choice.final_inputs, choice.final_verifier = functions


def main(argv: list[str]) -> int:
    from sample_rows import build, variant_rows

    out_dir, seed, names = Path(argv[0]), int(argv[1]), argv[2].split(",")
    functions = {v: patched(v) for v in names}
    _, method, dataset, protocol = build(seed, argv[3:])

    def method_for(v: str):
        use(functions[v])
        return method

    variant_rows(out_dir, seed, names, dataset, protocol, method_for)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
