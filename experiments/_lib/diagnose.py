"""Why ours fails on real scans: per-candidate diagnosis and input-defect ablations.

For every sample of a real set (``bench suite real``'s sets, ``gt_model`` protocol) this runs
``method=ours`` while keeping its ``m`` candidate poses, and records:

- the error of every candidate (before refinement), the selected one, the oracle (best of the
  ``m``), whether a correct candidate (< 10 deg) existed, and the selection criterion
  (Chamfer, tilt, gravity-kept) of the selected and of the best candidate;
- input quality against the ground truth: residual of observed points to the posed model
  surface (object unit and mm where known), fraction further than ``bleed_mm`` (mask bleed /
  background), normal error (deg, sign-free) against the model's normal at the nearest point,
  ground-normal error and the angle between the object's up axis and the ground normal;
- the depth-only ambiguity test of issue 10: the mean distance of observed points to the
  model posed at the estimate, and at the ground truth;

and optionally re-runs ours on corrected inputs (``--ablate``): points further than
``bleed_mm`` from the posed ground-truth model removed (``trim``), normals replaced by the
model's (``gt_normals``), the exact ground normal (``gt_ground``), points projected onto the
model surface (``denoise``), the object's true up (in the object frame) given as the template up
(``true_up``), every correction at once (``all``).

    python experiments/_lib/diagnose.py --set ycbv --out /tmp/diag_ycbv.jsonl [--ablate trim,gt_normals]

Ground truth is used here for diagnosis only, never by a method.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

ABLATIONS = ("none", "trim", "gt_normals", "gt_ground", "denoise", "true_up", "all")


class _MeshDistance:
    """Distances and closest points of query points (object frame) to a triangle mesh."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray) -> None:
        from catpose.o3d import o3d

        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(
            o3d.core.Tensor(np.asarray(vertices, np.float32)), o3d.core.Tensor(np.asarray(triangles, np.uint32))
        )

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(distances (N,), closest points (N, 3), unit normals of the closest triangles (N, 3))."""
        from catpose.o3d import o3d

        q = o3d.core.Tensor(np.asarray(points, np.float32))
        ans = self.scene.compute_closest_points(q)
        closest = ans["points"].numpy().astype(np.float64)
        normals = ans["primitive_normals"].numpy().astype(np.float64)
        return np.linalg.norm(closest - points, axis=1), closest, normals


class _CloudDistance:
    """The same queries against a point cloud with normals (templates without a mesh)."""

    def __init__(self, points: np.ndarray, normals: np.ndarray) -> None:
        from scipy.spatial import cKDTree

        self.points, self.normals, self.tree = points, normals, cKDTree(points)

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d, j = self.tree.query(points)
        return d, self.points[j], self.normals[j]


def _transform(T: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ T[:3, :3].T + T[:3, 3]


class RecordingOurs:
    """Wraps an ``Ours`` instance and keeps the candidate poses of the last ``register``."""

    def __init__(self, ours) -> None:
        self.ours = ours
        self.candidates: np.ndarray | None = None
        original = ours.candidates

        def candidates(*args, **kwargs):
            c = original(*args, **kwargs)
            self.candidates = c.T.copy()
            return c

        ours.candidates = candidates

    def register(self, problem):
        return self.ours.register(problem)


def ablate(problem, sample, mesh: _MeshDistance, which: str, bleed: float):
    """The problem with one input defect corrected from the ground truth (diagnosis only)."""
    T_oc = np.asarray(sample.gt.T_template_camera, float)
    T_co = np.linalg.inv(T_oc)
    p, n, g = problem.points_camera, problem.normals_camera, problem.ground_normal_camera
    template = problem.template
    d, closest, mn = mesh.query(_transform(T_oc, p))
    fix = {"trim", "gt_normals", "gt_ground", "denoise", "true_up"} if which == "all" else {which}
    if "denoise" in fix:
        p = _transform(T_co, closest)
    if "gt_normals" in fix:
        nn = mn @ T_co[:3, :3].T
        flip = np.einsum("ij,ij->i", nn, -p) < 0
        nn[flip] *= -1
        n = nn
    if "gt_ground" in fix or "true_up" in fix:
        g = T_co[:3, :3] @ np.asarray(template.up, float)
    if "true_up" in fix:
        # the real support direction: the measured ground normal in the object frame
        g_meas = problem.ground_normal_camera
        up = T_oc[:3, :3] @ g_meas
        template = dataclasses.replace(template, up=up / np.linalg.norm(up))
        g = g_meas
    if "trim" in fix:
        keep = d < bleed
        if keep.sum() >= 20:
            p, n = p[keep], n[keep]
    return dataclasses.replace(problem, points_camera=p, normals_camera=n, ground_normal_camera=g, template=template)


def diagnose(
    set_name: str,
    ablations: list[str],
    limit: int | None,
    out: Path,
    bleed_mm: float,
    ours_overrides: list[str],
    save_dir: Path | None = None,
) -> None:
    from catpose.bench.real.suite import compose
    from catpose.bench.real.suite_sets import METHODS, SETS
    from catpose.bench.run.build import build_parts
    from catpose.bench.run.config import shared_data_dir
    from catpose.bench.run.sample_run import seed_everything
    from catpose.bench.scoring.metrics import sample_errors
    from catpose.geometry import stable_seed
    from catpose.methods.choice_rules import rotation_angle_deg

    cfg, _ = compose(SETS[set_name], METHODS["ours"], shared_data_dir(), 0, limit, "outputs/real", ours_overrides)
    _, ours, dataset, protocol = build_parts(cfg)
    rec = RecordingOurs(ours)
    ids = protocol.sample_ids(dataset)[: limit or None]
    meshes: dict[str, _MeshDistance] = {}
    with open(out, "a") as f:
        for sid in ids:
            sample = protocol.load(dataset, sid)
            problem, gt = sample.problem, sample.gt
            tpl = problem.template
            if tpl.template_id not in meshes:
                meshes[tpl.template_id] = (
                    _MeshDistance(tpl.vertices, tpl.triangles)
                    if tpl.has_mesh
                    else _CloudDistance(tpl.points, tpl.normals)
                )
            mesh = meshes[tpl.template_id]
            scale_mm = sample.info.get("scale_mm")
            bleed = bleed_mm / scale_mm if scale_mm else bleed_mm / 100.0  # ModelNet: 1 unit ~ 100 mm
            T_oc = np.asarray(gt.T_template_camera, float)
            d_obs, _, mn = mesh.query(_transform(T_oc, problem.points_camera))
            n_obj = problem.normals_camera @ T_oc[:3, :3].T
            nerr = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", n_obj, mn)), 0, 1)))
            up_cam = np.linalg.inv(T_oc)[:3, :3] @ np.asarray(tpl.up, float)
            ground_err = float(np.degrees(np.arccos(np.clip(up_cam @ problem.ground_normal_camera, -1, 1))))
            base = {
                "set": set_name,
                "sample_id": sid,
                "scale_mm": scale_mm,
                "residual_median": float(np.median(d_obs)),
                "residual_mean": float(d_obs.mean()),
                "bleed_fraction": float((d_obs > bleed).mean()),
                "normal_err_median_deg": float(np.median(nerr)),
                "normal_err_mean_deg": float(nerr.mean()),
                "ground_vs_up_deg": ground_err,
            }
            for which in ablations:
                prob = problem if which == "none" else ablate(problem, sample, mesh, which, bleed)
                seed_everything(stable_seed(0, sid))
                res = rec.register(prob)
                T_est = np.asarray(res.T_template_camera, float)
                ex = res.extras

                def err(T):
                    return sample_errors(T, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)["err_deg"]

                if "depth_score" in ex and res.candidates_T is not None:
                    # the depth rule: every gravity hypothesis' expanded candidates (template frame);
                    # "selected" is the one nearest the answer (the answer is it, refined)
                    cand = np.asarray(res.candidates_T, float)
                    sel = int(np.argmin([rotation_angle_deg(T[:3, :3], T_est[:3, :3]) for T in cand]))
                else:
                    cand, sel = rec.candidates, int(ex["template_index"])
                cand_err = [float(err(T)) for T in cand]
                best = int(np.argmin(cand_err))
                # depth-only ambiguity: observed points to the posed model, at the estimate and the truth
                d_est = float(mesh.query(_transform(T_est, prob.points_camera))[0].mean())
                d_gt = float(mesh.query(_transform(T_oc, prob.points_camera))[0].mean())
                row = dict(
                    base,
                    ablation=which,
                    err_deg=float(err(T_est)),
                    selected=sel,
                    selected_cand_err=cand_err[sel],
                    oracle=best,
                    oracle_err=cand_err[best],
                    correct_exists=bool(min(cand_err) < 10),
                    n_correct=int(sum(e < 10 for e in cand_err)),
                    cand_err=cand_err,
                    chamfer=ex.get("chamfer"),
                    tilt_deg=ex.get("tilt_deg"),
                    kept=ex.get("kept"),
                    losses=ex.get("losses"),
                    depth_score=ex.get("depth_score"),
                    escalated=ex.get("escalated"),
                    fit_est=d_est,
                    fit_gt=d_gt,
                    fit_est_mm=d_est * scale_mm if scale_mm else None,
                    fit_gt_mm=d_gt * scale_mm if scale_mm else None,
                    n_points=int(len(prob.points_camera)),
                )
                if save_dir is not None:  # inputs and candidates, to score selection rules offline
                    from catpose import atomic

                    with atomic.atomic_path(save_dir / f"{sid.replace('/', '_')}__{which}.npz") as tmp:
                        np.savez_compressed(
                            tmp,
                            points=prob.points_camera,
                            normals=prob.normals_camera,
                            ground=prob.ground_normal_camera,
                            candidates=cand,
                            T_est=T_est,
                            T_gt=np.asarray(gt.T_template_camera, float),
                            template_id=tpl.template_id,
                            up=np.asarray(prob.template.up, float),
                            cand_err=np.array(cand_err),
                            chamfer=np.array(ex.get("chamfer", []), float),
                            tilt=np.array(ex.get("tilt_deg", []), float),
                            losses=np.array([np.nan if x is None else x for x in ex.get("losses", [])], float),
                            scale_mm=np.nan if scale_mm is None else float(scale_mm),
                        )
                f.write(json.dumps(row) + "\n")
                f.flush()
                log.info(
                    f"{sid} [{which}] err {row['err_deg']:.1f} sel {cand_err[sel]:.1f} oracle {cand_err[best]:.1f} "
                    f"n_ok {row['n_correct']} bleed {base['bleed_fraction']:.2f} nerr {base['normal_err_median_deg']:.1f} "
                    f"up {ground_err:.1f} fit est/gt {d_est:.4f}/{d_gt:.4f}"
                )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python experiments/_lib/diagnose.py",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--set", default="ycbv")
    parser.add_argument("--ablate", default="none", help=f"comma-separated subset of {', '.join(ABLATIONS)}")
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--bleed-mm", type=float, default=10.0)
    parser.add_argument("-o", "--ours-override", action="append", default=[])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--save-dir", type=Path, default=None, help="save inputs and candidate poses (npz)")
    args = parser.parse_args(argv)
    from catpose import logs
    from catpose.bench.real.suite_sets import SETS
    from catpose.errors import CatposeError

    logs.configure("", prefix="diagnose")  # its progress lines on stderr
    ablations = args.ablate.split(",")
    unknown = [a for a in ablations if a not in ABLATIONS]
    try:
        if args.set not in SETS:
            raise CatposeError(f"--set {args.set!r} is unknown; use one of {', '.join(SETS)}")
        if unknown:
            raise CatposeError(
                f"--ablate {','.join(unknown)} unknown; use a comma-separated subset of {', '.join(ABLATIONS)}"
            )
        diagnose(args.set, ablations, args.limit, args.out, args.bleed_mm, args.ours_override, args.save_dir)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
