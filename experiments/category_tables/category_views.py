"""Per-view errors of one method in a category-level sweep, with what kind of error each is
(``python experiments/category_tables/category_views.py SWEEP_DIR --row ours --out views.csv``).

For every scored view (the ``templates`` protocol's chosen registration) it writes the instance,
view, chosen template, error, the oracle error, and the residual rotation ``R_gt^T R_est`` as an
angle and the angle of its axis from the template's up axis (z): a residual near 180 degrees about
the vertical axis is a nose/tail (front/back) swap, one about a horizontal axis an upside-down
turn; ``turn_deg``, under the ``cross_top_turns`` rule, the turn of the registration's estimate
that was kept (0: the estimate itself; empty under the other rules). This is the "per view, why
not" of docs/category-level.md.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

from catpose.errors import CatposeError, ConfigError


def residual(T_est: np.ndarray, T_gt: np.ndarray) -> tuple[float, float]:
    """(angle, axis tilt from +z) in degrees of ``R_gt^T R_est`` for (4, 4) poses (camera -> template)."""
    R = T_gt[:3, :3] @ T_est[:3, :3].T  # template-frame residual: R_est = R R_gt
    angle = float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))
    w, v = np.linalg.eigh((R + R.T) / 2)
    axis = v[:, int(np.argmax(w))]
    tilt = float(np.degrees(np.arccos(min(1.0, abs(float(axis[2]))))))
    return angle, tilt


def kind(angle: float, tilt: float) -> str:
    """A short name for a residual: ``right`` (< 30 deg), ``front/back`` (> 150 deg about an axis
    within 30 deg of vertical), ``upside-down`` (> 150 deg about a horizontal axis), ``other``."""
    if angle < 30:
        return "right"
    if angle > 150:
        return "front/back" if tilt < 30 else ("upside-down" if tilt > 60 else "other half turn")
    return "other"


def view_rows(sweep: str | Path, row: str) -> list[dict]:
    """Rows of the jobs of ``sweep`` whose overrides select ``+row=<row>``."""
    from catpose.bench.report.runs import load_run, protocol_of
    from catpose.bench.run.sweep import read_sweep

    jobs = [j for j in read_sweep(sweep) if f"+row={row}" in j.get("overrides", []) and j.get("run_dir")]
    if not jobs:
        raise ConfigError(f"sweep {sweep} has no finished job with +row={row}")
    out = []
    for j in jobs:
        run = load_run(j["run_dir"])
        units = protocol_of(run).score_units(run.samples)
        for r in units.to_dict("records"):
            T_est, T_gt = r.get("T_est"), r.get("T_gt")
            ok = r.get("status") == "ok" and T_est is not None
            angle, tilt = (
                residual(np.asarray(T_est, float).reshape(4, 4), np.asarray(T_gt, float).reshape(4, 4))
                if ok
                else (float("nan"), float("nan"))
            )
            out.append(
                {
                    "view": r["group_id"],
                    "instance_id": r.get("instance_id"),
                    "template_id": r.get("template_id"),
                    "err_deg": float(r["err_deg"]),
                    "oracle_err_deg": float(r.get("oracle_err_deg", r["err_deg"])),
                    "score": r.get("score"),
                    "residual_axis_tilt_deg": tilt,
                    "kind": kind(angle, tilt) if ok else "failed",
                    "turn_deg": info.get("turn_deg", "") if isinstance(info := r.get("info"), dict) else "",
                }
            )
    return sorted(out, key=lambda r: r["view"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python experiments/category_tables/category_views.py", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("sweep", help="a sweep directory of `bench run -m +experiment=...`")
    ap.add_argument("--row", default="ours", help="the +row of the jobs to list (default: ours)")
    ap.add_argument("--out", required=True, help="CSV to write")
    args = ap.parse_args(argv)
    try:
        rows = view_rows(args.sweep, args.row)
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    from catpose.atomic import atomic_write

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    print(f"wrote {len(rows)} views to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
