"""Depth statistics of the synthetic sensor model beside the real YCB-V frames (issue 10).

For each view: the residual of observed points to the ground-truth model surface (median and
mean, mm), the fraction of observed points further than 10 mm from it (mask bleed and
background), the fraction of object pixels without depth (missing), and the normal error
(median, deg, sign-free) of the observed normals against the model's.

    python -m catpose.bench.real.sensor_stats [--sensors kinect,realsense] [--categories can,bottle,mug]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def view_stats(
    points_object: np.ndarray, normals_object: np.ndarray, vertices: np.ndarray, triangles: np.ndarray, scale_mm: float
) -> dict:
    """Residual (mm), bleed fraction and normal error (deg) of one view in the object frame."""
    from catpose.bench.real.diagnose import _MeshDistance

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
    from catpose.datasets.depthio import read_depth_png, read_mask_png

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
        depth = read_depth_png(scene / "depth" / f"{info['im_id']:06d}.png")
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


def main(argv: list[str] | None = None) -> int:
    import pandas as pd

    from catpose.bench.run.config import shared_data_dir

    parser = argparse.ArgumentParser(prog="python -m catpose.bench.real.sensor_stats", description=__doc__)
    parser.add_argument("--sensors", default="kinect,realsense")
    parser.add_argument("--categories", default="can,bottle,mug")
    parser.add_argument("--instances", type=int, default=2)
    parser.add_argument("--views", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
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
