"""Ours with a poor-fit test that leaves a mask's bleed out of its count: one JSON line per sample
and variant (study: README.md).

    python experiments/bleed_fit/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [OVERRIDE ...]
    python experiments/bleed_fit/run.py --bench VARIANT BENCH_ARG ...   # `bench` with the variant installed

Ours' poor-fit test (``methods/ours/choice.py``, ``poor_fit``) asks what fraction of the mask's
pixels ``depth_fit_erode_px`` or more inside its edge (and within the object's depth span) the
winner explains within ``FIT_TAU``. ``bleed-aware`` (:func:`bleed_aware_fit`, installed in place of
:meth:`catpose.methods.ours.check.DepthVerifier.fit` for that call only) leaves out of the count
the inner pixels the winner leaves empty whose observed depth lies more than ``FIT_TAU`` behind
the farthest, or in front of the nearest, depth the winner renders: a bleed onto the table behind
the object or onto something in front of it, which no pose of the object could explain; a
template unlike the object leaves the object's own pixels unexplained, and those lie within its
depth. Nothing else changes (``experiments/_lib/patched_runs.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

VARIANTS = ("default", "bleed-aware")
ORIGINAL: dict = {}


def bleed_aware_fit(self, T_template_camera, tolerance=None, erode_px=0):
    """:meth:`DepthVerifier.fit` with the explained fraction of the poor-fit test (``erode_px`` > 0)
    counted over the inner pixels less the bleed (module docstring); the free-space column as ours."""
    if erode_px <= 0:
        return ORIGINAL["fit"](self, T_template_camera, tolerance, erode_px)
    out = ORIGINAL["fit"](self, T_template_camera, tolerance, erode_px)
    L = self.lattice
    tol = self.tau if tolerance is None else float(tolerance)
    inner = self._inner_mask(int(erode_px))
    for b, (win, r) in enumerate(self.render(T_template_camera, min(tol, self.tau))):
        if win is None or not (r > 0).any():
            continue
        R = np.zeros_like(L.depth)
        R[win] = r
        o, hit = L.depth, R > 0
        near, far = float(R[hit].min()), float(R[hit].max())
        explained = inner & hit & (np.abs(R - o) <= tol)
        bleed = inner & ~hit & (o > 0) & ((o > far + tol) | (o < near - tol))
        out[b, 0] = explained.sum() / max(int(inner.sum() - bleed.sum()), 1)
    return out


def install(variant: str) -> None:
    """Install ``variant``'s fit (``default``: ours' own) in this process."""
    from catpose.methods.ours.check import DepthVerifier

    ORIGINAL.setdefault("fit", DepthVerifier.fit)
    DepthVerifier.fit = bleed_aware_fit if variant == "bleed-aware" else ORIGINAL["fit"]


if __name__ == "__main__":
    from patched_runs import main

    sys.exit(main(sys.argv[1:], {v: (lambda v=v: install(v)) for v in VARIANTS}))
