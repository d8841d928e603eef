"""Build the chair development root of the template choice (issue 25) in a folder outside the
repository, from the shared data only: the 3 ModelNet40 train chair meshes (``chair_0001``,
``chair_0002``, ``chair_0059``) and the ShapeNet chair (written as ``chair_9001``), each sampled
to 10,000 points with face normals in PointNet++'s resampled layout (y up; the OFF meshes' axes
mapped as the loader expects), beside links to the shared resampled chairs that are the K = 3
templates, a split file and an alignment table (every dev chair needs no turn: checked by eye on
the alignment contact sheet, and ``experiments/alignment/align.py`` with reference chair_0391
estimates yaw 0 for all four).

Usage: python experiments/category_choice/chair_dev_root.py SHARED_DATA OUT_ROOT
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_lib"))
from procedural import HEADER  # noqa: E402  (experiments/_lib/procedural.py)

DEV = {
    "chair_0001": "ModelNet40/chair/train/chair_0001.off",
    "chair_0002": "ModelNet40/chair/train/chair_0002.off",
    "chair_0059": "ModelNet40/chair/train/chair_0059.off",
    "chair_9001": "shapenet/chair/models/model_normalized.obj",
}
TEMPLATES = ("chair_0391", "chair_0624", "chair_0848")


def resampled(mesh: trimesh.Trimesh, off: bool) -> np.ndarray:
    """(10000, 6) points and normals on ``mesh``; OFF meshes (z up) are put y up with x negated."""
    pts, face = trimesh.sample.sample_surface_even(mesh, 10000, seed=0)
    if len(pts) < 10000:
        more, more_face = trimesh.sample.sample_surface(mesh, 10000 - len(pts), seed=1)
        pts, face = np.vstack([pts, more]), np.concatenate([face, more_face])
    nrm = mesh.face_normals[face]
    if off:
        flip = np.array([-1.0, 1.0, 1.0])
        pts, nrm = pts[:, [0, 2, 1]] * flip, nrm[:, [0, 2, 1]] * flip
    return np.hstack([pts, nrm])


def main(shared: str, out: str) -> None:
    shared_p, root = Path(shared), Path(out)
    (root / "chair").mkdir(parents=True, exist_ok=True)
    rows = []
    for name, rel in DEV.items():
        mesh = trimesh.load(shared_p / rel, force="mesh")
        np.savetxt(root / "chair" / f"{name}.txt", resampled(mesh, rel.endswith(".off")), delimiter=",", fmt="%.6f")
        rows.append(
            f"chair,{name},1,0,0,0,1,0,0,0,1,0,false,,,true,dev: checked by eye on bench align's contact sheet\n"
        )
    for name in TEMPLATES:
        link = root / "chair" / f"{name}.txt"
        if not link.exists():
            link.symlink_to((shared_p / "modelnet40_normal_resampled" / "chair" / f"{name}.txt").resolve())
        rows.append(f"chair,{name},1,0,0,0,1,0,0,0,1,0,false,,,true,shared template (results/alignment/)\n")
    (root / "modelnet40_train.txt").write_text("".join(f"{n}\n" for n in sorted([*DEV, *TEMPLATES])))
    (root / "modelnet40_test.txt").write_text("")
    (root / "alignment_chair.csv").write_text(HEADER + "".join(rows))
    print(f"wrote {len(DEV)} development chairs and {len(TEMPLATES)} template links to {root}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python experiments/category_choice/chair_dev_root.py SHARED_DATA OUT_ROOT")
    main(sys.argv[1], sys.argv[2])
