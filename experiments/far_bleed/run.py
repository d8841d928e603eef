"""Ours on masks that bleed onto a background metres behind the object, with and without the trim
of the mask to the object's depth span: one JSON line per sample and variant (study: README.md).

    python experiments/far_bleed/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [--far] [OVERRIDE ...]

``VARIANT``: ``default`` (ours unchanged) or ``trim`` (ours on the problem whose mask and points keep
only the pixels within :data:`REACH` of the mask's median depth), ``trim-points`` and ``trim-mask`` (only the points, only the mask), ``trim-points-fit`` (the points, and the poor-fit
test's pixels: the check's mask unchanged); ``icp``, ``ppf`` (their defaults)
and ``icp+trim``, ``ppf+trim``. ``--far``: every instance's mask
is first corrupted as ``dataset.mask_noise`` does, then bleeds onto a far background
(:func:`far_bleed`), patched into the loader in this process only. ``OVERRIDE``s are ``bench
run``'s; problems are built and ours seeded per sample as ``bench run`` does
(``experiments/_lib/sample_rows.py``).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

#: the template's diameter, object-normalised unit: no pixel of the object lies further than this
#: from the depth of another of its pixels, so none further from the mask's median depth
REACH = 2.0
#: the far blob: at most this fraction of the mask's pixels (the issue's tuna can: over 5 %)
FAR_FRACTION = 0.10
#: the far background: this many metres behind the mask's median depth (the issue's: 1.2-2.1 m)
FAR_METRES = (0.5, 2.5)


def trimmed(problem, points: bool = True, mask: bool = True):
    """``problem`` with its points (``points``) and its mask (``mask``) cut to those within
    :data:`REACH` of the mask's median depth (the object unit)."""
    from catpose.types import DepthImage

    im = problem.depth_image
    d, m = im.depth, im.mask & (im.depth > 0)
    z = float(np.median(d[m]))
    keep_px = m & (np.abs(d - z) <= REACH) if mask else im.mask
    keep = np.abs(problem.points_camera[:, 2] - z) <= REACH if points else np.ones(len(problem.points_camera), bool)
    return replace(
        problem,
        points_camera=problem.points_camera[keep],
        normals_camera=problem.normals_camera[keep],
        depth_image=DepthImage(d, im.K, keep_px),
    )


#: ours' variants: unchanged; its points and mask trimmed; only its points; only its mask
OURS = ("default", "trim", "trim-points", "trim-mask", "trim-points-fit")
#: the other methods the study runs (what the far bleed does to them, and the trim)
OTHERS = ("icp", "ppf")


class Trimmed:
    """A method registering :func:`trimmed` problems (those with a depth image)."""

    def __init__(self, method, points: bool = True, mask: bool = True, fit: bool = False) -> None:
        self.method, self.points, self.mask, self.fit = method, points, mask, fit

    def register(self, problem):
        global _FIT_IN_SPAN
        if problem.depth_image is None:
            return self.method.register(problem)
        _FIT_IN_SPAN = self.fit
        try:
            return self.method.register(trimmed(problem, self.points, self.mask))
        finally:
            _FIT_IN_SPAN = False


_FIT_IN_SPAN = False  # while a Trimmed(fit=True) registers


def install_fit_in_span() -> None:
    """Patch ours' depth check: while :data:`_FIT_IN_SPAN`, the poor-fit test's inner mask leaves out
    the lattice pixels further than :data:`REACH` from the mask's median depth."""
    from catpose.methods.ours.check import DepthVerifier

    inner_mask = DepthVerifier._inner_mask

    def inner_in_span(self, erode_px):
        inner = inner_mask(self, erode_px)
        if not _FIT_IN_SPAN:
            return inner
        d, m = self.image.depth, self.image.mask & (self.image.depth > 0)
        kept = inner & (np.abs(self.lattice.depth - float(np.median(d[m]))) <= REACH)
        return kept if kept.any() else inner

    DepthVerifier._inner_mask = inner_in_span


_FAR: dict[str, tuple[np.ndarray, float]] = {}  # frame id -> (the blob's pixels, their depth in mm)


def far_bleed(mask: np.ndarray, depth_mm: np.ndarray, seed: int, frame_id: str) -> np.ndarray:
    """``mask`` joined by a disc of up to :data:`FAR_FRACTION` of its pixels centred on a pixel just
    outside it (the part not already in the mask), whose depth becomes a background
    :data:`FAR_METRES` behind the mask's median depth (recorded for the frame's depth image)."""
    from scipy import ndimage

    from catpose.geometry import stable_seed

    rng = np.random.default_rng(stable_seed("far-bleed", seed, frame_id))
    n = int(mask.sum())
    ring = np.argwhere(ndimage.binary_dilation(mask, np.ones((3, 3), bool)) & ~mask)
    if not len(ring) or not n:
        return mask
    cy, cx = ring[int(rng.integers(len(ring)))]
    radius = np.sqrt(rng.uniform(0.0, FAR_FRACTION) * n / np.pi)
    yy, xx = np.mgrid[0 : mask.shape[0], 0 : mask.shape[1]]
    blob = ((yy - cy) ** 2 + (xx - cx) ** 2 <= radius * radius) & ~mask
    z = float(np.median(depth_mm[mask & (depth_mm > 0)])) + 1000.0 * rng.uniform(*FAR_METRES)
    _FAR[frame_id] = (blob, z)
    return mask | blob


def install_far_bleed() -> None:
    """Patch the BOP loader (so ``dataset=ycbv`` and ``dataset=clutter``): masks corrupted as before,
    then :func:`far_bleed`; the depth frame reads the far background on the blob."""
    from catpose.datasets import bop

    corrupt, frame_cls = bop.corrupt_mask, bop.DepthFrame

    def corrupt_far(mask, depth_mm, strength, seed, frame_id):
        return far_bleed(corrupt(mask, depth_mm, strength, seed, frame_id), depth_mm, seed, frame_id)

    def frame_far(raw_depth, K, mask, depth_scale, frame_id, seed):
        blob, z_mm = _FAR.pop(frame_id, (None, 0.0))
        if blob is not None:
            raw_depth = np.array(raw_depth, dtype=np.float64)
            raw_depth[blob] = z_mm / depth_scale
        return frame_cls(raw_depth, K, mask, depth_scale, frame_id=frame_id, seed=seed)

    bop.corrupt_mask, bop.DepthFrame = corrupt_far, frame_far


def main(argv: list[str]) -> int:
    from sample_rows import build, variant_rows

    out_dir, seed, names = Path(argv[0]), int(argv[1]), argv[2].split(",")
    rest = argv[3:]
    if "--far" in rest:
        rest.remove("--far")
        install_far_bleed()
    from catpose.bench.run.config import compose_and_build

    bad = [v for v in names if v not in OURS and v.removesuffix("+trim") not in OTHERS]
    if bad:
        raise SystemExit(f"{bad}: variants are default, trim, and {', '.join(OTHERS)} with or without +trim")
    _, ours, dataset, protocol = build(seed, rest)
    methods = {"default": ours, "trim": Trimmed(ours), "trim-points": Trimmed(ours, mask=False)}
    methods["trim-mask"] = Trimmed(ours, points=False)
    methods["trim-points-fit"] = Trimmed(ours, mask=False, fit=True)
    install_fit_in_span()
    for v in names:
        if v.removesuffix("+trim") in OTHERS:
            other = compose_and_build([f"method={v.removesuffix('+trim')}"], ["method"])[1][0][1]
            methods[v] = Trimmed(other) if v.endswith("+trim") else other
    variant_rows(out_dir, seed, names, dataset, protocol, methods.__getitem__)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
