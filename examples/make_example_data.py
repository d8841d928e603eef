"""Write the small files the README's and docs/api.md's examples load (``examples/data/``).

A procedural chair of the embedded synthetic set (``catpose.datasets.shapes``, seed 3) in
millimetres, standing on a floor, seen by a 200 x 150 depth camera from 2.2 m:

- ``chair.ply``: the chair's mesh (the template), mm, z up, its origin away from the chair's centre;
- ``chair_frame.npz``: ``depth`` (150, 200) uint16 mm (floor and chair, 0 where nothing was
  hit), ``K`` (3, 3) pixels, ``mask`` (150, 200) bool, the chair's visible pixels, and
  ``T_template_camera`` (4, 4), the true pose (mm: ``p_template = R p_camera + t``).

Deterministic (rendering is the same bits on every CPU, :func:`catpose.datasets.render.render_depth`).
Rerun: ``python examples/make_example_data.py`` (a few seconds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

MM_PER_UNIT = 450.0  # the chair's radius
OFFSET_MM = np.array([120.0, -35.0, 260.0])  # the template-frame origin, away from the chair's centre
OUT = Path(__file__).resolve().parent / "data"


def main(argv: list[str] | None = None) -> None:
    import argparse

    argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0] + f" Rewrites {OUT}; takes no arguments.",
        epilog="Rerun it only to change the examples: the tests and docs read these files.",
    ).parse_args(argv)
    import trimesh

    from catpose import atomic
    from catpose.datasets.render import render_depth
    from catpose.datasets.shapes import make_shape
    from catpose.datasets.views import pinhole_camera
    from catpose.geometry import axis_angle_to_R, invert_T, look_at_T_camera_world, make_T

    unit = make_shape("chair", np.random.default_rng(3))
    v_unit, faces = np.asarray(unit.vertices, float), np.asarray(unit.faces)
    # the chair in the world: turned 40 degrees about z, standing on the floor z = 0
    R_w = axis_angle_to_R(np.array([0.0, 0.0, 1.0]), np.deg2rad(40.0))
    t_w = np.array([0.0, 0.0, -MM_PER_UNIT * v_unit[:, 2].min()])
    v_world = (MM_PER_UNIT * v_unit) @ R_w.T + t_w
    floor = np.array([[-3000.0, -3000.0, 0.0], [3000.0, -3000.0, 0.0], [3000.0, 3000.0, 0.0], [-3000.0, 3000.0, 0.0]])
    scene_v = np.vstack([v_world, floor])
    scene_f = np.vstack([faces, len(v_world) + np.array([[0, 1, 2], [0, 2, 3]])])

    el, az = np.deg2rad(35.0), np.deg2rad(70.0)
    target = np.array([0.0, 0.0, t_w[2]])
    eye = target + 2200.0 * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    T_camera_world = look_at_T_camera_world(eye, target, np.array([0.0, 0.0, 1.0]))
    camera = pinhole_camera(200, 150, 200.0, 200.0)
    scene = render_depth(scene_v, scene_f, T_camera_world, camera).astype(np.float64)
    chair = render_depth(v_world, faces, T_camera_world, camera).astype(np.float64)
    mask = (chair > 0) & (np.abs(scene - chair) < 1.0)
    depth = np.round(scene).astype(np.uint16)

    # p_template = MM_PER_UNIT p_unit + OFFSET and p_world = R_w MM_PER_UNIT p_unit + t_w
    T_template_world = make_T(R_w.T, OFFSET_MM - R_w.T @ t_w)
    T_template_camera = T_template_world @ invert_T(T_camera_world)

    OUT.mkdir(exist_ok=True)
    mesh = trimesh.Trimesh(MM_PER_UNIT * v_unit + OFFSET_MM, faces, process=False)
    atomic.write_bytes(OUT / "chair.ply", mesh.export(file_type="ply"))
    with atomic.atomic_path(OUT / "chair_frame.npz") as tmp:
        np.savez_compressed(tmp, depth=depth, K=camera.K, mask=mask, T_template_camera=T_template_camera)
    print(f"wrote {OUT / 'chair.ply'} and {OUT / 'chair_frame.npz'} ({int(mask.sum())} chair pixels)")


if __name__ == "__main__":
    main()
