"""``bench align``: estimate a category's per-instance alignment table for ModelNet40.

Every instance of a category (in the configured split) is compared with a reference instance
over a set of candidate rotations (N yaw steps about +z, ``yaw4`` by default since ModelNet40
files share their up axis; or all 24 axis-aligned rotations with ``--rotations 24``);
the rotation with the lowest Chamfer distance between the normalised surface samples is
written to a CSV that ``dataset=modelnet40 dataset.alignment_table=<csv>`` applies::

    bench align --root /data/ModelNet40 --category airplane --split train \\
        --reference airplane_0001 --out airplane_alignment.csv
"""

from __future__ import annotations

import argparse
import sys


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bench align", description=__doc__.split("\n\n")[0])
    p.add_argument("--root", required=True, help="ModelNet40 root (<category>/<split>/*.off)")
    p.add_argument("--category", required=True, action="append",
                   help="category to align (repeat for several)")
    p.add_argument("--split", default="train", help="split whose instances are aligned (default train)")
    p.add_argument("--reference", default=None,
                   help="reference instance id (default: the first instance of the category)")
    p.add_argument("--rotations", default="yaw4",
                   help="'yaw<N>': N yaw steps about +z (default yaw4; keeps the up axis), or '24': "
                        "all axis-aligned rotations (for files whose up axis also varies)")
    p.add_argument("--points", type=int, default=1024, help="surface samples per shape")
    p.add_argument("--up", default="+z", help="the files' up axis (default +z)")
    p.add_argument("--forward", default="+x", help="the files' forward axis (default +x)")
    p.add_argument("--out", required=True, help="CSV file to write")
    p.add_argument("--seed", type=int, default=0)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command; returns the exit status (2 on a user error, printed as one line)."""
    args = build_parser().parse_args(argv)
    from catpose.errors import CatposeError

    try:
        rows = align(args)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {len(rows)} rows to {args.out}")
    return 0


def align(args: argparse.Namespace) -> list[dict]:
    from catpose.datasets.alignment import (estimate_alignment, rotation_candidates,
                                            write_alignment_table, yaw_deg_of)
    from catpose.datasets.meshio import sample_outer_surface
    from catpose.datasets.modelnet40 import ModelNet40
    from catpose.errors import DatasetError
    from catpose.geometry import stable_seed

    candidates = rotation_candidates(args.rotations)
    ds = ModelNet40(args.root, categories=args.category, split=args.split, up=args.up,
                    forward=args.forward, seed=args.seed)
    rows: list[dict] = []
    for category in args.category:
        ids = ds.instance_ids(category)
        if not ids:
            raise DatasetError(f"no {args.split}-split OFF files in {args.root}/{category}/{args.split}")
        ref_id = args.reference or ids[0]

        def cloud(instance_id: str):
            v, f = ds.canonical_mesh(category, instance_id)
            return sample_outer_surface(v, f, args.points, stable_seed(args.seed, "align", instance_id))[0]

        reference = cloud(ref_id)
        for instance_id in ids:
            R, cost = estimate_alignment(reference, cloud(instance_id), candidates)
            rows.append({"category": category, "instance_id": instance_id, "R": R,
                         "yaw_deg": yaw_deg_of(R), "chamfer": cost})
            print(f"{category}/{instance_id}: chamfer {cost:.4f}, yaw {yaw_deg_of(R)}", file=sys.stderr)
    write_alignment_table(args.out, rows)
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
