"""Depth statistics of the synthetic sensor model beside the real YCB-V frames (issue 10).

For each view: the residual of observed points to the ground-truth model surface (median and
mean, mm), the fraction of observed points further than 10 mm from it (mask bleed and
background), the fraction of object pixels without depth (missing), and the normal error
(median, deg, sign-free) of the observed normals against the model's.

    python experiments/_lib/sensor_stats.py [--sensors kinect,realsense] [--categories can,bottle,mug]

``--clutter`` instead sets the cluttered synthetic set (``dataset=clutter``, its first
``--scenes`` scenes, generated if missing) beside the real YCB-V frames, instance by instance from
the files of both (:func:`frame_rows`: the model rendered at the written ground truth against the
depth image and the segmentation), per object and pooled, with the camera's distance and
elevation above the table:

    python experiments/_lib/sensor_stats.py --clutter --scenes 40 [--out results/clutter/sensor_vs_real.md]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def view_stats(
    points_object: np.ndarray, normals_object: np.ndarray, vertices: np.ndarray, triangles: np.ndarray, scale_mm: float
) -> dict:
    """Residual (mm), bleed fraction and normal error (deg) of one view in the object frame."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from diagnose import _MeshDistance  # the sibling script (experiments/_lib/diagnose.py)

    d, _, mn = _MeshDistance(vertices, triangles).query(points_object)
    d_mm = d * scale_mm
    nerr = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", normals_object, mn)), 0, 1)))
    return {
        "residual_median_mm": float(np.median(d_mm)),
        "residual_mean_mm": float(d_mm.mean()),
        "bleed_fraction": float((d_mm > 10.0).mean()),
        "normal_err_median_deg": float(np.median(nerr)),
    }


def synthetic_rows(sensor: str, categories: list[str], instances: int, views: int, seed: int) -> list[dict]:
    from catpose.datasets.synthetic import SyntheticDataset

    ds = SyntheticDataset(
        seed=seed, categories=categories, instances_per_category=instances, views_per_instance=views, sensor=sensor
    )
    rows = []
    for oid in ds.observation_ids():
        o = ds.observation(oid)
        m = ds.instance_model(o.category, o.instance_id)
        T = np.asarray(o.T_object_camera)
        s = view_stats(
            o.points_camera @ T[:3, :3].T + T[:3, 3],
            o.normals_camera @ T[:3, :3].T,
            m.vertices,
            m.triangles,
            o.info["scale_mm"],
        )
        rows.append(
            dict(source=f"synthetic/{sensor}", category=o.category, missing_fraction=o.info["missing_fraction"], **s)
        )
    return rows


def ycbv_rows(root: str, seed: int) -> list[dict]:
    from pathlib import Path

    from catpose.bench.protocols.absolute import GtModel
    from catpose.datasets.bop import BOP
    from catpose.datasets.depthio import read_depth, read_mask_png

    ds = BOP(root, categories={1: "can", 5: "bottle", 9: "can"}, seed=seed)
    proto = GtModel()
    rows = []
    for sid in proto.sample_ids(ds):
        sample = proto.load(ds, sid)
        p, tpl = sample.problem, sample.problem.template
        T = np.asarray(sample.gt.T_template_camera)
        s = view_stats(
            p.points_camera @ T[:3, :3].T + T[:3, 3],
            p.normals_camera @ T[:3, :3].T,
            tpl.vertices,
            tpl.triangles,
            sample.info["scale_mm"],
        )
        info = sample.info
        scene = Path(root) / "test" / f"{info['scene_id']:06d}"
        depth = read_depth(scene / "depth" / f"{info['im_id']:06d}.png")
        mask = read_mask_png(scene / "mask_visib" / f"{info['im_id']:06d}_{info['gt_idx']:06d}.png")
        rows.append(
            dict(
                source="real/ycbv",
                category=f"{p.category}-obj{info['obj_id']}",
                missing_fraction=float((depth[mask] == 0).mean()),
                **s,
            )
        )
    return rows


#: frame statistics of :func:`frame_rows`, in table order, with what each measures
FRAME_STATS = {
    "missing": "object pixels (the model at the truth, in front of the depth) without depth",
    "missing_edge": "the same within 2 px of the object's silhouette",
    "missing_inner": "the same further inside (dark or shiny parts)",
    "off10": "segmented pixels with depth more than 10 mm off the model at the truth (or off it)",
    "residual_abs_mm": "median |depth - model at the truth| over segmented pixels within 30 mm",
    "residual_mm": "median signed depth - model at the truth (negative: depth in front)",
    "mask_vs_silhouette_px": "mean distance between the segmentation's and the silhouette's borders",
    "distance_mm": "camera to object centre",
    "elevation_deg": "camera above the table seen from the object (plane fit to the background)",
}


def frame_rows(root, scenes: list[int] | None = None, source: str = "") -> list[dict]:
    """One row of :data:`FRAME_STATS` per instance of the BOP folder ``root`` (``test/``; depth
    PNGs, ``mask_visib`` segmentations, ``scene_gt.json``, ``models/``), scenes ``scenes`` (None:
    all). The model is ray-cast at the written ground truth; its pixels in front of the depth
    image (or where the depth is missing) are the object's."""
    import json
    from pathlib import Path

    from scipy.ndimage import binary_erosion, distance_transform_edt

    from catpose.datasets.clutter_render import object_depth
    from catpose.datasets.depthio import fit_ground_plane, read_depth, read_mask_png
    from catpose.datasets.meshio import read_mesh
    from catpose.datasets.render import PinholeCamera, depth_to_points
    from catpose.geometry import make_T
    from catpose.raycast import RayCaster

    root, casters, rows = Path(root), {}, []
    for scene in sorted(p for p in (root / "test").iterdir() if p.is_dir() and p.name.isdigit()):
        if scenes is not None and int(scene.name) not in scenes:
            continue
        gt = json.loads((scene / "scene_gt.json").read_text())
        cams = json.loads((scene / "scene_camera.json").read_text())
        for im, objs in gt.items():
            K = np.asarray(cams[im]["cam_K"], float).reshape(3, 3)
            depth = read_depth(scene / "depth" / f"{int(im):06d}.png") * float(cams[im].get("depth_scale", 1.0))
            camera = PinholeCamera.from_K(K, depth.shape[1], depth.shape[0])
            labels = [read_mask_png(scene / "mask_visib" / f"{int(im):06d}_{k:06d}.png") for k in range(len(objs))]
            background = (depth > 0) & ~np.any(labels, axis=0)
            n, d, _ = fit_ground_plane(depth_to_points(depth, camera, background)[0][::7], 10.0, 1000, 0)
            for label, g in zip(labels, objs):
                o = int(g["obj_id"])
                if o not in casters:
                    casters[o] = RayCaster(*read_mesh(root / "models" / f"obj_{o:06d}.ply"))
                t = np.asarray(g["cam_t_m2c"], float)
                r = object_depth(casters[o], make_T(np.asarray(g["cam_R_m2c"], float).reshape(3, 3), t), camera)
                obj = (r > 0) & ((depth == 0) | (r <= depth + 15.0))
                if obj.sum() < 50 or (label & (depth > 0)).sum() < 50:
                    continue
                edge = obj & ~binary_erosion(obj, iterations=2)
                seg = label & (depth > 0)
                res = (depth - r)[seg & (r > 0)]
                near = np.abs(res) < 30.0
                borders = [m & ~binary_erosion(m) for m in (label, obj)]
                rows.append(
                    {
                        "source": source,
                        "object": f"obj {o}",
                        "missing": float((depth[obj] == 0).mean()),
                        "missing_edge": float((depth[edge] == 0).mean()),
                        "missing_inner": float((depth[obj & ~edge] == 0).mean()) if (obj & ~edge).any() else 0.0,
                        "off10": float((seg & ((r == 0) | (np.abs(depth - r) > 10.0))).sum() / seg.sum()),
                        "residual_abs_mm": float(np.median(np.abs(res[near]))) if near.any() else float("nan"),
                        "residual_mm": float(np.median(res[near])) if near.any() else float("nan"),
                        "mask_vs_silhouette_px": float(
                            np.concatenate(
                                [distance_transform_edt(~obj)[borders[0]], distance_transform_edt(~label)[borders[1]]]
                            ).mean()
                        ),
                        "distance_mm": float(np.sqrt(t @ t)),
                        "elevation_deg": float(np.degrees(np.arcsin(np.clip(-(n @ t) / np.sqrt(t @ t), -1, 1)))),
                    }
                )
    return rows


def frames_table(rows: list[dict]) -> str:
    """Markdown: median of :data:`FRAME_STATS` per source and object, then per source."""
    import pandas as pd

    df = pd.DataFrame(rows)
    cols = list(FRAME_STATS)
    per = df.groupby(["source", "object"])[cols].median().reset_index()
    per.insert(2, "n", df.groupby(["source", "object"]).size().to_numpy())
    pooled = df.groupby("source")[cols].median().reset_index().assign(object="all")
    pooled.insert(2, "n", df.groupby("source").size().to_numpy())
    table = pd.concat([pooled, per])[["source", "object", "n", *cols]]
    notes = "\n".join(f"- {k}: {v}" for k, v in FRAME_STATS.items())
    return table.to_markdown(index=False, floatfmt=".3f") + "\n\nMedians over instances.\n\n" + notes + "\n"


def clutter_frames(scenes: int) -> tuple[str, list[int]]:
    """The folder of the default ``dataset=clutter`` set of the shared models, its first
    ``scenes`` scenes generated if missing."""
    from catpose.bench.run.config import compose_and_build

    _, [(_, dataset)] = compose_and_build(
        [
            "method=icp",
            "dataset=clutter",
            f"dataset.root={_shared()}/bop/ycbv",
            f"dataset.scenes={list(range(scenes))}",
        ],
        ["dataset"],
    )
    dataset.observation_ids()  # generates what is missing
    return str(dataset.root), list(range(scenes))


def _shared():
    from catpose.bench.run.config import shared_data_dir

    return shared_data_dir()


def main(argv: list[str] | None = None) -> int:
    import pandas as pd

    from catpose.bench.run.config import shared_data_dir

    parser = argparse.ArgumentParser(prog="python experiments/_lib/sensor_stats.py", description=__doc__)
    parser.add_argument("--sensors", default="kinect,realsense")
    parser.add_argument("--categories", default="can,bottle,mug")
    parser.add_argument("--instances", type=int, default=2)
    parser.add_argument("--views", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--clutter", action="store_true", help="the clutter set's frames beside the real YCB-V frames")
    parser.add_argument("--scenes", type=int, default=40, help="--clutter: its first N scenes")
    parser.add_argument("--out", default=None, help="--clutter: also write the table to this file")
    args = parser.parse_args(argv)
    if args.clutter:
        root, scenes = clutter_frames(args.scenes)
        rows = frame_rows(_shared() / "bop" / "ycbv", None, "real YCB-V") + frame_rows(root, scenes, "clutter")
        text = frames_table(rows)
        print(text)
        if args.out:
            from catpose import atomic

            atomic.write_text(args.out, text)
        return 0
    rows = []
    ycbv = shared_data_dir() / "bop" / "ycbv"
    if ycbv.is_dir():
        rows += ycbv_rows(str(ycbv), args.seed)
    for sensor in args.sensors.split(","):
        rows += synthetic_rows(sensor, args.categories.split(","), args.instances, args.views, args.seed)
    df = pd.DataFrame(rows)
    table = df.groupby(["source", "category"]).median(numeric_only=True).reset_index()
    pooled = df.groupby("source").median(numeric_only=True).reset_index().assign(category="all")
    print(pd.concat([table, pooled]).to_markdown(index=False, floatfmt=".3f"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
