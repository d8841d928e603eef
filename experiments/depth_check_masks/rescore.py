"""Which part of a dirty mask misleads ours' depth check, and which robust statistic of the check
survives it? One JSON line per sample (study: README.md).

    python experiments/depth_check_masks/rescore.py OUT.jsonl SEED [noise:COMPONENT] [OVERRIDE ...]

Ours runs as ``bench run`` runs it (``experiments/_lib/sample_rows.py``'s problem building:
same problems, same per-sample seed), its answer and found@10 (the best pose it held at any stage,
``extras["hypothesis_stages"]``) are recorded, and then ours' held poses (the stages ``pool``,
``expanded`` and ``final_refine``) are re-scored here, on ours' final lattice
(:func:`catpose.methods.ours.check.final_verifier`), by the plain cost of
:mod:`catpose.methods.ours.check` and by robust variants of it (:data:`VARIANTS`); each variant's
answer is the held pose of lowest cost. Only public names of ours are used; nothing of ours changes.

``check:VARIANT`` (a name of :data:`VARIANTS`) replaces ours' depth check by that variant in this
process, for the whole run (the search, the choice), so the answer is what ours would give with it.

``noise:COMPONENT`` (``dilate``, ``erode``, ``bleed``) replaces the loader's
:func:`catpose.datasets.mask_noise.corrupt_mask` by the same draws with one component alone: the
edge always dilated (or always eroded) by ``round(3 s)`` pixels and no blobs, or the blobs alone.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

_SQUARE = np.ones((3, 3), dtype=bool)
STAGES = ("pool", "expanded", "final_refine")
#: the re-scoring variants: name -> (kind, parameter)
VARIANTS = {
    "plain": ("plain", 0),
    "edge 2 px": ("edge", 2),
    "edge 4 px": ("edge", 4),
    "MAD band c=2": ("mad", 2.0),
    "MAD band c=3": ("mad", 3.0),
    "trimmed 10 %": ("trim", 0.10),
    "trimmed 20 %": ("trim", 0.20),
    "trimmed 30 %": ("trim", 0.30),
    "grown 3 px in MAD band c=3": ("grow", 3),
}


def component_noise(component: str):
    """:func:`catpose.datasets.mask_noise.corrupt_mask` with one component alone (same draws)."""
    from catpose.geometry import stable_seed

    def corrupt(mask, depth, strength, seed, frame_id):
        mask = np.asarray(mask, dtype=bool)
        if strength <= 0 or not mask.any():
            return mask.copy()
        rng = np.random.default_rng(stable_seed("mask-noise", seed, frame_id))
        s = float(rng.uniform(0.0, strength))
        out = mask.copy()
        r = int(round(3.0 * s))
        if r > 0:
            rng.random()  # the draw of dilate or erode, kept so later draws match
            if component == "dilate":
                out = ndimage.binary_dilation(out, _SQUARE, iterations=r)
            elif component == "erode":
                eroded = ndimage.binary_erosion(out, _SQUARE, iterations=r)
                out = eroded if eroded.any() else out
        if component != "bleed":
            return out
        measured = np.asarray(depth) > 0
        ring = np.argwhere(ndimage.binary_dilation(mask, _SQUARE) & ~mask)
        n_blobs = int(rng.poisson(4.0 * s)) if len(ring) else 0
        h, w = mask.shape
        yy, xx = np.mgrid[0:h, 0:w]
        for _ in range(n_blobs):
            cy, cx = ring[int(rng.integers(len(ring)))]
            radius = float(rng.uniform(1.0, 2.0 + 10.0 * s))
            y0, y1 = max(cy - int(radius) - 1, 0), cy + int(radius) + 2
            x0, x1 = max(cx - int(radius) - 1, 0), cx + int(radius) + 2
            disc = (yy[y0:y1, x0:x1] - cy) ** 2 + (xx[y0:y1, x0:x1] - cx) ** 2 <= radius * radius
            out[y0:y1, x0:x1] |= disc & measured[y0:y1, x0:x1] & ~mask[y0:y1, x0:x1]
        return out

    return corrupt


class Rescorer:
    """The plain cost and its robust variants of poses on one verifier's lattice."""

    def __init__(self, verifier) -> None:
        self.v = verifier
        L = verifier.lattice
        self.Z, self.M = L.depth, L.mask  # observed depth, mask (lattice)
        image_mask = np.asarray(verifier.image.mask, bool)
        self.inner, self.outer = {}, {}
        for k in (2, 3, 4):
            er = ndimage.binary_erosion(image_mask, _SQUARE, iterations=k)[np.ix_(L.rows, L.cols)]
            self.inner[k] = er if er.any() else self.M
            self.outer[k] = ndimage.binary_dilation(image_mask, _SQUARE, iterations=k)[np.ix_(L.rows, L.cols)]
        od = self.Z[self.M & (self.Z > 0)]
        self.med = float(np.median(od)) if od.size else 0.0
        self.mad = 1.4826 * float(np.median(np.abs(od - self.med))) if od.size else 0.0
        # grown: the mask and the pixels within 3 px outside it whose depth lies in the band (c = 3)
        band = (self.Z > 0) & (np.abs(self.Z - self.med) <= 3.0 * self.mad)
        self.grown = self.M | (self.outer[3] & band)

    def costs(self, T: np.ndarray, only: str | None = None) -> dict[str, np.ndarray]:
        """Per variant (``only``: that one), the (B,) costs of poses ``T`` (B, 4, 4)."""
        v, Z, M = self.v, self.Z, self.M
        tau, fw = v.tau, v.free_weight
        variants = {only: VARIANTS[only]} if only else VARIANTS
        out = {name: np.full(len(T), np.inf) for name in variants}
        for b, (win, r) in enumerate(v.render(np.asarray(T, float).reshape(-1, 4, 4))):
            if win is None:
                continue
            R = np.zeros_like(Z)
            R[win] = r
            c = np.where(R > 0, np.minimum(np.abs(R - Z), tau) / tau, 1.0)
            free = ~M & (R > 0) & (Z > 0) & (Z - R > tau)
            for name, (kind, p) in variants.items():
                if kind == "plain":
                    val = (c[M].sum() + fw * free.sum()) / max(M.sum(), 1)
                elif kind == "edge":
                    inner = self.inner[p]
                    val = (c[inner].sum() + fw * (free & ~self.outer[p]).sum()) / max(inner.sum(), 1)
                elif kind == "grow":
                    g = self.grown
                    val = (c[g].sum() + fw * (free & ~g).sum()) / max(g.sum(), 1)
                elif kind == "mad":
                    keep = M & (np.abs(Z - self.med) <= p * self.mad) if self.mad > 0 else M
                    keep = keep if keep.any() else M
                    val = (c[keep].sum() + fw * free.sum()) / max(keep.sum(), 1)
                else:
                    cm = np.sort(c[M])
                    n = max(int(np.ceil((1.0 - p) * len(cm))), 1)
                    val = (cm[:n].sum() + fw * free.sum()) / n
                out[name][b] = val
        return out


def patch_check(variant: str) -> None:
    """Ours' depth check (:meth:`DepthVerifier.scores`, every stage that ranks poses by it) replaced
    in this process by the variant ``variant`` of :data:`VARIANTS` (its fits, the poor-fit flag's
    measure, unchanged)."""
    from catpose.methods.ours.check import DepthVerifier

    if variant not in VARIANTS:
        raise SystemExit(f"check:{variant}: not one of {', '.join(VARIANTS)}")

    def scores(self, T_template_camera):
        scorer = self.__dict__.get("_study_rescorer")
        if scorer is None:
            scorer = self.__dict__["_study_rescorer"] = Rescorer(self)
        return scorer.costs(T_template_camera, variant)[variant]

    DepthVerifier.scores = scores


def main(argv: list[str]) -> int:
    from sample_rows import answer_errors, build, done_ids, register_seeded

    from catpose.bench.scoring.metrics import pose_errors_deg
    from catpose.methods.ours.check import final_verifier

    out, seed = Path(argv[0]), int(argv[1])
    rest = argv[2:]
    for item in rest:
        if item.startswith("noise:"):
            import catpose.datasets.bop as bop

            bop.corrupt_mask = component_noise(item[len("noise:") :])
        elif item.startswith("check:"):
            patch_check(item[len("check:") :])
    _, method, dataset, protocol = build(seed, [a for a in rest if not a.startswith(("noise:", "check:"))])
    done = done_ids(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    t_all = time.time()
    with out.open("a") as f:
        for sid in protocol.sample_ids(dataset):
            if sid in done:
                continue
            s = protocol.load(dataset, sid)
            p, gt = s.problem, s.gt
            r, _ = register_seeded(method, p, seed, sid)
            _, err, _, found = answer_errors(r, gt)
            hs = r.extras.get("hypothesis_stages", {})
            row = {"sample_id": sid, "seed": seed, "category": p.category, "err_deg": err, "found_err_deg": found}
            held = [np.asarray(hs[k], float).reshape(-1, 4, 4) for k in STAGES if k in hs and len(hs[k])]
            if held and p.depth_image is not None:
                H = np.concatenate(held)
                errs = pose_errors_deg(H, gt.T_template_camera, gt.symmetry_axis, list(gt.symmetries))
                scorer = Rescorer(final_verifier(method.selection, p))
                costs = scorer.costs(H)
                row["held_found_deg"] = float(errs.min())
                row["pick_err_deg"] = {name: float(errs[int(np.argmin(c))]) for name, c in costs.items()}
                row["mask_pixels"] = int(scorer.M.sum())
            f.write(json.dumps(row) + "\n")
            f.flush()
    print(f"{out}: done in {time.time() - t_all:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
