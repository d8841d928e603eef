"""Where in the image ours' half-turned answers explain the depth better than the truth (study:
README.md).

    python experiments/flip_regions/run.py OUT.md RUN_DIR [RUN_DIR ...]

For every answer of the ``gt_model`` runs given that is a flip (at least ``FLIP_DEG`` from the
truth) the template is rendered at the answer and at the truth refined as ours refines its last
poses (``experiments/_lib/ambiguity.py``'s ``refined_truth``), on every pixel (a lattice of stride 1),
and the depth check's per-pixel cost of each (``methods/ours/check_kernel.py``'s ``window_cost``:
``min(|r - o|, tau) / tau`` on the mask, 1 where the rendering leaves a mask pixel empty, the
free-space weight outside the mask where the rendering lies more than ``tau`` in front of the
observation) is summed per region: the mask's pixels at most 2, 3-5 and more than 5 pixels inside
its edge, the pixels outside it at most 2 and more than 2 pixels away. Each sum is divided by the
mask's pixel count (the check's score is the sum of all five). Per object: views, how many the
answer wins overall and in each region, and the median difference (answer minus truth; below 0:
the answer explains that region better).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

REGIONS = ("mask edge <= 2 px", "mask 3-5 px in", "mask > 5 px in", "outside <= 2 px", "outside > 2 px")


def region_costs(verifier, T: np.ndarray) -> np.ndarray:
    """(B, 5): the per-region sums of :data:`REGIONS` of each pose of ``T`` (B, 4, 4) over the
    mask's pixel count, ``verifier`` on a lattice of stride 1."""
    from scipy import ndimage

    L = verifier.lattice
    o, m = L.depth, L.mask
    inside, outside = ndimage.distance_transform_edt(m), ndimage.distance_transform_edt(~m)
    parts = (
        m & (inside <= 2),
        m & (inside > 2) & (inside <= 5),
        m & (inside > 5),
        ~m & (outside <= 2),
        ~m & (outside > 2),
    )
    out = []
    for win, rd in verifier.render(T, None):
        r = np.zeros_like(o)
        if win is not None:
            r[win] = rd
        c = np.zeros_like(o)
        hit = m & (r > 0)
        c[hit] = np.minimum(np.abs(r[hit] - o[hit]), verifier.tau) / verifier.tau
        c[m & ~(r > 0)] = 1.0
        c[~m & (r > 0) & (o > 0) & (o - r > verifier.tau)] = verifier.free_weight
        out.append([c[p].sum() / m.sum() for p in parts])
    return np.asarray(out)


def flip_rows(run_dir: Path) -> list[dict]:
    """One row per flipped answer of ``run_dir``: sample, object, the five regions' differences
    and the check's two scores (stride 1)."""
    from ambiguity import FLIP_DEG, _run_parts, refined_truth

    from catpose.methods.ours.check import DepthVerifier

    sel, dataset, protocol = _run_parts(run_dir)
    rows = [json.loads(line) for line in (run_dir / "samples.jsonl").read_text().splitlines() if line.strip()]
    out = []
    for r in rows:
        if r.get("status") != "ok" or float(r["err_deg"]) < FLIP_DEG:
            continue
        s = protocol.load(dataset, r["sample_id"])
        p = s.problem
        n = int(p.depth_image.mask.sum())
        v = DepthVerifier(p.template, p.depth_image, sel.depth_tau, 10 * n, 10**9, sel.depth_free_weight)
        T = np.stack(
            [
                np.asarray(r["T_est"], float).reshape(4, 4),
                refined_truth(sel, p, np.asarray(s.gt.T_template_camera, float)),
            ]
        )
        costs = region_costs(v, T)
        out.append(
            {
                "sample_id": r["sample_id"],
                "seed": r["seed"],
                "obj_id": int(r["info"]["obj_id"]),
                "diff": (costs[0] - costs[1]).tolist(),
                "score_answer": float(costs[0].sum()),
                "score_truth": float(costs[1].sum()),
            }
        )
    return out


def main(argv: list[str]) -> int:
    from sample_rows import OBJECTS, write_table

    out, runs = Path(argv[0]), [Path(a) for a in argv[1:]]
    rows = [x for run in runs for x in flip_rows(run)]
    lines = [
        "**Ours' flipped answers on the shared YCB-V frames: where they explain the depth better than the truth**",
        "",
        "| object | flipped answers | answer cheaper overall | "
        + " | ".join(f"answer cheaper: {g}" for g in REGIONS)
        + " |",
        "|" + "---|" * (3 + len(REGIONS)),
    ]
    for obj in sorted({x["obj_id"] for x in rows}):
        g = [x for x in rows if x["obj_id"] == obj]
        d = np.array([x["diff"] for x in g])
        cells = [
            f"{OBJECTS.get(obj, obj)} (obj {obj})",
            str(len(g)),
            f"{sum(x['score_answer'] < x['score_truth'] for x in g)}",
        ]
        cells += [f"{int((d[:, k] < 0).sum())} (median {np.median(d[:, k]):+.4f})" for k in range(len(REGIONS))]
        lines.append("| " + " | ".join(cells) + " |")
    lines += [
        "",
        f"Written by `experiments/flip_regions/run.py` from {len(runs)} runs in `{runs[0].parent}`. Flipped: the answer",
        "at least 150 deg from the truth; the truth refined as ours refines its last poses. Each region's figure:",
        "in how many views the answer costs less there, and the median difference (answer minus truth) of",
        "the region's summed per-pixel cost over the mask's pixel count; the check's score is the sum of the five.",
    ]
    return write_table(out, lines)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
