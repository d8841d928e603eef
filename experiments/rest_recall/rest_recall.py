"""Every resting pose found? Per object and per stable rest of its model, whether ours' pose pool
held a pose within 10 deg of the truth (found@10), one JSON line per sample (study: README.md).

    python experiments/rest_recall/rest_recall.py OUT.jsonl SEED [OVERRIDE ...]

``OVERRIDE``s are ``bench run``'s (``dataset=clutter dataset.root=... 'dataset.scenes=[0,1]'
dataset.mask_noise=1.0``, ``method.resting.grid_yaws=12``), or ``const:MODULE.NAME=VALUE`` for a
named constant of a stage module of ours (``const:rest_search.KEEP=16``: a variant of the study,
not a key); the problems are built and ours is seeded
per sample as ``bench run`` builds and seeds them, so the answers are the run's. Ours is read
through its result only (``extras["hypothesis_stages"]``, ``extras["resting_up"]``); the truth's
rest is the model's stable rest class (:func:`catpose.resting.rest_classes`) nearest the ground
normal seen in the model frame at the true pose. Finished samples already in OUT are skipped.
"""

from __future__ import annotations

import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))

#: a rest within this of the truth's up (deg; under a symmetry axis, of its angle to the axis) is
#: the truth's rest; farther, the object does not lie in a stable rest of its model ("none")
REST_TOL_DEG = 15.0


def rest_labels(template) -> list[dict]:
    """The model's stable rest classes (most probable first): up (template frame), probability, label."""
    from catpose.resting import rest_classes, resting_ups_cached

    geometry = template.vertices if template.has_mesh else template.points
    axis = template.symmetry_axis
    out = []
    for rep, _ in rest_classes(resting_ups_cached(np.asarray(geometry, float)), axis):
        up = rep.vector / np.linalg.norm(rep.vector)
        if axis is not None:
            a = np.degrees(np.arccos(np.clip(up @ (np.asarray(axis, float) / np.linalg.norm(axis)), -1, 1)))
            label = "axis up" if a < 20 else "axis down" if a > 160 else f"side ({a:.0f} deg to axis)"
        else:
            label = "up ({:+.2f}, {:+.2f}, {:+.2f})".format(*up)
        out.append({"up": up.tolist(), "probability": float(rep.probability), "label": label})
    return out


def rest_of(T_template_camera: np.ndarray, g_camera: np.ndarray, rests: list[dict], axis) -> tuple[int, float]:
    """The rest class (index into ``rests``, -1: none within :data:`REST_TOL_DEG`) of a pose, and
    its angle to it (deg)."""
    u = np.asarray(T_template_camera)[:3, :3] @ (np.asarray(g_camera, float) / np.linalg.norm(g_camera))
    ups = np.array([r["up"] for r in rests])
    if axis is None:
        d = np.degrees(np.arccos(np.clip(ups @ u, -1.0, 1.0)))
    else:
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        d = np.abs(np.degrees(np.arccos(np.clip(ups @ a, -1, 1))) - np.degrees(np.arccos(np.clip(u @ a, -1, 1))))
    k = int(np.argmin(d))
    return (k if d[k] <= REST_TOL_DEG else -1), float(d[k])


def main(argv: list[str]) -> int:
    from sample_rows import answer_errors, build, done_ids, register_seeded

    out, seed = Path(argv[0]), int(argv[1])
    overrides = [a for a in argv[2:] if not a.startswith("const:")]
    for item in argv[2:]:
        if item.startswith("const:"):
            name, value = item[len("const:") :].split("=", 1)
            module, attr = name.rsplit(".", 1)
            target = importlib.import_module(f"catpose.methods.ours.{module}")
            if not hasattr(target, attr) or attr.startswith("_"):
                raise SystemExit(f"{item}: catpose.methods.ours.{module} has no public constant {attr}")
            setattr(target, attr, json.loads(value))
    cfg, method, dataset, protocol = build(seed, overrides)
    done = done_ids(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    t_all = time.time()
    with out.open("a") as f:
        ids = protocol.sample_ids(dataset)
        for sid in ids[: cfg.limit] if cfg.get("limit") is not None else ids:
            if sid in done:
                continue
            s = protocol.load(dataset, sid)
            p, gt = s.problem, s.gt
            r, runtime = register_seeded(method, p, seed, sid)
            T, err, stages, found = answer_errors(r, gt)
            rests = rest_labels(p.template)
            axis = p.template.symmetry_axis
            truth, truth_off = rest_of(gt.T_template_camera, p.ground_normal_camera, rests, axis)
            answer, _ = rest_of(T, p.ground_normal_camera, rests, axis)
            row = {
                "sample_id": sid,
                "seed": seed,
                "obj_id": s.info.get("obj_id"),
                "category": p.category,
                "status": "ok",
                "err_deg": err,
                "found_err_deg": found,
                "stages": stages,
                "rests": rests,
                "truth_rest": truth,
                "truth_rest_off_deg": truth_off,
                "answer_rest": answer,
                "poor_fit": bool(r.extras.get("depth_poor_fit", False)),
                "runtime_s": runtime,
                # what catpose.bench.real.suite_table.estimate reads: the seeds' agreement
                "T_est": T.reshape(-1).tolist(),
                "T_gt": np.asarray(gt.T_template_camera, float).reshape(-1).tolist(),
                "symmetry_axis": None if gt.symmetry_axis is None else np.asarray(gt.symmetry_axis, float).tolist(),
                "symmetries": [np.asarray(S, float).reshape(-1).tolist() for S in gt.symmetries] or None,
            }
            f.write(json.dumps(row) + "\n")
            f.flush()
    print(f"{out}: done in {time.time() - t_all:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
