"""How well ours' depth check separates the truth from its half turns and from ours' wrong answer
(study: README.md).

    python experiments/check_separation/separation.py --set ycbv|clutter [--seeds 0,1,2] [--limit N] \
        [--variants NAME,...] --out results/check_separation/ycbv_dev.md [--force]

Per sample of the set's development part (``ycbv``: the shared YCB-V frames of scene 1,
``configs/split/ycbv.yaml`` part ``scene1``; ``clutter``: clutter dev scenes 0-14 with segmenter-like
masks, ``dataset.mask_noise=1``), the template is rendered at the ground truth and at each of its
half turns about the template's axes (those that are no symmetry of the object and no spin about
its symmetry axis), each as given and refined as ours refines its last poses (the final lattice's
mask pixels against a fixed mesh sample), and scored by each
variant of the check (:data:`VARIANTS`) on the lattice of ours' final comparison. A pose's cost
is the lower of its two; the sample's margin is the best turn's cost minus the truth's (> 0: the
check prefers the truth). Ours at its defaults registers the sample too: when its answer is
wrong (>= 10 deg), its margin against the truth under each variant is recorded.

Ground truth is read here for diagnosis only, never by the method.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from catpose import atomic
from catpose.errors import CatposeError

#: the check's variants: name -> (tau, object unit; normal weight; noise_tau, in units of the
#: observed depth's noise (0: tau as given))
VARIANTS = {
    "tau0.15": (0.15, 0.0, 0.0),
    "tau0.08": (0.08, 0.0, 0.0),
    "tau0.04": (0.04, 0.0, 0.0),
    "tau0.02": (0.02, 0.0, 0.0),
    "tau0.15+n0.5": (0.15, 0.5, 0.0),
    "tau0.15+n1": (0.15, 1.0, 0.0),
    "tau0.08+n1": (0.08, 1.0, 0.0),
    "noise3": (0.15, 0.0, 3.0),
    "noise6": (0.15, 0.0, 6.0),
    "noise6+n1": (0.15, 1.0, 6.0),
}
#: margins of the separation curve (the truth beats every turn by more than this)
MARGINS = (0.0, 0.01, 0.02, 0.05, 0.1)
WRONG_DEG = 10.0


def lattice_normals(depth: np.ndarray, dirs: np.ndarray, jump: float) -> np.ndarray:
    """(h, w, 3) unit normals of the surface a depth image (h, w; 0: none) shows along the rays
    ``dirs`` (h, w, 3, z = 1): the cross product of the central differences of the back-projected
    points between lattice neighbours, oriented towards the camera; 0 where a neighbour has no
    depth or lies more than ``jump`` (depth unit) from the pixel (an edge)."""
    P = depth[..., None] * dirs
    n = np.zeros_like(P)
    if depth.shape[0] < 3 or depth.shape[1] < 3:
        return n
    c = depth[1:-1, 1:-1]
    ok = c > 0
    for nb in (depth[1:-1, 2:], depth[1:-1, :-2], depth[2:, 1:-1], depth[:-2, 1:-1]):
        ok &= (nb > 0) & (np.abs(nb - c) <= jump)
    m = np.cross(P[1:-1, 2:] - P[1:-1, :-2], P[2:, 1:-1] - P[:-2, 1:-1])
    length = np.sqrt((m * m).sum(axis=-1))
    ok &= length > 0
    m = np.where(ok[..., None], m / np.where(ok, length, 1.0)[..., None], 0.0)
    m *= np.where((m * P[1:-1, 1:-1]).sum(axis=-1) > 0, -1.0, 1.0)[..., None]  # towards the camera
    n[1:-1, 1:-1] = m
    return n


def depth_noise(depth: np.ndarray, mask: np.ndarray) -> float:
    """The observed depth's noise inside the object's mask, in the depth unit: the root mean
    square of the second differences along rows and along columns of neighbouring mask pixels
    with depth, the largest tenth left out (edges, steps between surfaces), over sqrt(6) (the
    spread of a second difference of independent noise). It holds the sensor's quantisation (a
    median would be 0 where most steps are)."""
    m = mask & (depth > 0)
    parts = []
    for a, mm in ((depth, m), (depth.T, m.T)):
        ok = mm[:, :-2] & mm[:, 1:-1] & mm[:, 2:]
        parts.append((a[:, :-2] - 2.0 * a[:, 1:-1] + a[:, 2:])[ok])
    a = np.sort(np.abs(np.concatenate(parts)))
    a = a[: max(int(0.9 * len(a)), 1)]
    return float(np.sqrt((a * a).mean() / 6.0)) if len(a) else 0.0


def variant_verifier(template, image, tau: float, normal_weight: float, noise_tau: float, pixels: int, free: float):
    """Ours' check (:class:`~catpose.methods.ours.check.DepthVerifier`, the final lattice of
    ``pixels``) with a variant's tolerance (``noise_tau`` > 0: that many times
    :func:`depth_noise`, at most ``tau``) and, with ``normal_weight`` > 0, each mask pixel where
    both the rendering and the observation have a normal (:func:`lattice_normals`) also costing
    ``normal_weight * (1 - n_r . n_o) / 2``."""
    from catpose.methods.ours.check import DEPTH_MAX_RAYS, DEPTH_PIXELS, DepthVerifier

    noise = noise_tau * depth_noise(image.depth, image.mask) if noise_tau > 0 else 0.0
    tau = min(tau, noise) if noise > 0 else tau

    class Variant(DepthVerifier):
        def scores(self, T):
            base = super().scores(T)
            if normal_weight <= 0:
                return base
            L = self.lattice
            n_obs = lattice_normals(L.depth, L.dirs, self.tau)
            n_mask = max(self.mask_pixels, 1)
            out = base.copy()
            for b, (win, r) in enumerate(self.render(T)):
                if win is None:
                    continue
                n_r = lattice_normals(r, L.dirs[win], self.tau)
                o = n_obs[win]
                both = L.mask[win] & ((o * o).sum(-1) > 0) & ((n_r * n_r).sum(-1) > 0)
                out[b] += normal_weight * float(((1.0 - (o * n_r).sum(-1)[both]) / 2.0).sum()) / n_mask
            return out

    return Variant(template, image, tau, pixels, DEPTH_MAX_RAYS * pixels // DEPTH_PIXELS, free)


def _spin(F: np.ndarray, axis) -> bool:
    """Whether the half turn ``F`` (4, 4) is about the symmetry ``axis`` (3,): no other pose."""
    if axis is None:
        return False
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    return bool(np.abs(F[:3, :3] @ a - a).max() < 1e-6)


def _set_overrides(name: str, shared: str) -> tuple[list[str], str | None]:
    if name == "ycbv":
        return ["dataset=ycbv", f"dataset.root={shared}/bop/ycbv"], "scene1"
    if name == "clutter":
        scenes = ",".join(str(s) for s in range(15))
        return ["dataset=clutter", f"dataset.root={shared}/bop/ycbv", f"dataset.scenes=[{scenes}]",
                "dataset.mask_noise=1.0"], None  # fmt: skip
    raise CatposeError(f"--set {name}: use ycbv or clutter")


def sample_rows(set_name: str, seed: int, limit: int | None, variants: list[str], shared: str) -> list[dict]:
    """One row per sample: object, ours' error, and per variant the margins."""
    from catpose.bench.real.split import load_split
    from catpose.bench.run.build import build_dataset, build_protocol
    from catpose.bench.run.config import compose
    from catpose.bench.scoring.metrics import pose_errors_deg
    from catpose.geometry import compose_T
    from catpose.methods.ours import Ours
    from catpose.methods.ours.check import final_verifier
    from catpose.methods.ours.refine import final_inputs, refine_poses
    from catpose.methods.ours.settings import SelectionSettings
    from catpose.methods.pose_scores import half_turns

    overrides, part = _set_overrides(set_name, shared)
    cfg = compose([*overrides, "method=ours", f"seed={seed}"])
    dataset, protocol = build_dataset(cfg.dataset), build_protocol(cfg)
    ids = protocol.sample_ids(dataset)
    if part is not None:
        ids = load_split(set_name).sample_ids(part, ids)
    ids = ids[:limit] if limit else ids
    ours, sel = Ours(), SelectionSettings()
    rows = []
    for sid in ids:
        np.random.seed(0)
        s = protocol.load(dataset, sid)
        p, gt = s.problem, s.gt
        T_gt = np.asarray(gt.T_template_camera, float)
        axis, syms = gt.symmetry_axis, gt.symmetries
        turns = [compose_T(F, T_gt) for F in half_turns()[1:] if not _spin(F, p.template.symmetry_axis)]  # fmt: skip
        turns = [T for T in turns if pose_errors_deg(T[None], T_gt, axis, syms)[0] >= WRONG_DEG]
        est = ours.register(p).T_template_camera
        err = float(pose_errors_deg(est[None], T_gt, axis, syms)[0])
        raw = np.stack([T_gt, *turns, est])
        ref = refine_poses(*final_inputs(final_verifier(sel, p), p.template), raw[:-1])  # as ours' last step
        row = {"sample_id": sid, "obj": int(s.info.get("obj_id", -1)), "seed": seed, "err": err, "turns": len(turns)}
        for v in variants:
            tau, nw, noise = VARIANTS[v]
            ver = variant_verifier(
                p.template, p.depth_image, tau, nw, noise, sel.depth_final_pixels, sel.depth_free_weight
            )
            c_raw, c_ref = ver.scores(raw), ver.scores(ref)
            c = np.minimum(c_raw[:-1], c_ref)
            row[v] = {
                "truth": float(c[0]),
                "margin": float(c[1:].min() - c[0]) if turns else None,
                "answer_margin": float(c_raw[-1] - c[0]) if err >= WRONG_DEG else None,
                "tau": ver.tau,
            }
        rows.append(row)
        print(sid, f"err {err:.1f}", {v: row[v]["margin"] for v in variants}, flush=True)
    return rows


def table(rows: list[dict], variants: list[str], title: str) -> str:
    """The separation curve per variant: fraction of samples with turns whose truth beats every
    turn by more than each margin; beside it, of ours' wrong answers, how many the truth beats."""
    with_turns = [r for r in rows if r["turns"]]
    wrong = [r for r in rows if r["err"] >= WRONG_DEG]
    cans = [r for r in with_turns if r["obj"] in (1, 4, 6, 9)]
    head = ["variant"] + [f"truth beats every turn by > {m:g}" for m in MARGINS]
    head += ["cans (obj 1, 4, 6, 9): > 0", "median margin", f"ours wrong: truth better (of {len(wrong)})", "tau"]
    out = [f"**{title}**", "", f"{len(rows)} samples, {len(with_turns)} with half turns, ours @10 "
           f"{1 - len(wrong) / max(len(rows), 1):.3f}", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]  # fmt: skip
    for v in variants:
        m = np.array([r[v]["margin"] for r in with_turns])
        cells = [v] + [f"{(m > t).mean():.3f}" for t in MARGINS]
        cells.append(f"{np.mean([r[v]['margin'] > 0 for r in cans]):.3f} (n={len(cans)})" if cans else "-")
        cells.append(f"{np.median(m):.4f}")
        cells.append(str(sum(r[v]["answer_margin"] > 0 for r in wrong)))
        cells.append(f"{np.median([r[v]['tau'] for r in rows]):.4f}")
        out.append("| " + " | ".join(cells) + " |")
    objs = sorted({r["obj"] for r in with_turns})
    out += ["", "Per object (BOP obj_id): the fraction whose truth beats every turn (> 0)", "",
            "| variant | " + " | ".join(f"obj {o} (n={sum(r['obj'] == o for r in with_turns)})" for o in objs) + " |",
            "|" + "---|" * (len(objs) + 1)]  # fmt: skip
    for v in variants:
        fr = [np.mean([r[v]["margin"] > 0 for r in with_turns if r["obj"] == o]) for o in objs]
        out.append(f"| {v} | " + " | ".join(f"{f:.3f}" for f in fr) + " |")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--set", required=True, choices=["ycbv", "clutter"])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args(argv)
    shared = os.environ.get("CATPOSE_SHARED_DATA", "../shared/data")
    variants = args.variants.split(",")
    try:
        if args.out.exists() and not args.force:
            raise CatposeError(f"{args.out} exists; pass --force to replace it")
        rows = []
        for seed in (int(s) for s in args.seeds.split(",")):
            rows += sample_rows(args.set, seed, args.limit, variants, shared)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        atomic.write_text(args.out.with_suffix(".jsonl"), "".join(json.dumps(r) + "\n" for r in rows))
        title = {"ycbv": "Shared YCB-V frames, scene 1 (development)",
                 "clutter": "Clutter dev scenes 0-14, segmenter-like masks (mask_noise 1)"}[args.set]  # fmt: skip
        atomic.write_text(args.out, table(rows, variants, f"{title}: the check's separation, seeds {args.seeds}"))
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
