"""Estimate, and draw for checking, a category's per-instance alignment table (the study's
command; it wrote the verified tables ``results/alignment/modelnet40_*.csv`` before a person
checked them).

Raw ModelNet40 instances differ by multiples of 90 degrees of yaw, so a category-level protocol
needs a rotation ``R_canonical_raw`` per instance (or the aligned release,
``dataset=modelnet40_aligned``). This command estimates one with no person in the loop: every instance is compared with every
other under each hypothesis (4 yaws, times an up-axis flip with ``--flip``), each hypothesis
refined by ICP and scored by symmetric Chamfer distance (which finds the main axis) plus shape cues
at the ends (which find the front of airplanes: ``--cues ends``, what the default ``auto`` gives
airplanes; ``alignment_cues.py``); a consensus over all pairs picks each instance's hypothesis in
the reference instance's frame (``alignment_estimate.estimate_table``). ``--compare VERIFIED.csv``
then measures the written estimate against a verified table (``align_check.py``). It writes

- a CSV (``--out``) that ``dataset.alignment_table=<csv>`` applies, with ``confidence`` (relative
  margin between the best and second-best hypothesis) and ``verified`` (false: set it to true,
  with a ``note``, once you have checked the row on the sheet);
- a contact sheet PNG (``--sheet``, default beside the CSV): each instance (colour) over the
  reference (grey) in its estimated alignment, top view (x forward, y left) and side view
  (x forward, z up); rows with low confidence, or where the consensus and the reference-only
  estimate disagree, are titled in red::

    python experiments/alignment/align.py dataset=modelnet40 dataset.root=/data/ModelNet40 \\
        --category airplane --reference airplane_0001 --out results/alignment/modelnet40_airplane.csv

A bad input is one line (``align.py: error: ...``) and exit status 2.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling scripts

log = logging.getLogger("catpose.align")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python experiments/alignment/align.py", description=__doc__.split("\n\n")[0])
    p.add_argument(
        "overrides", nargs="*", help="Hydra dataset overrides: dataset=modelnet40|modelnet40_resampled dataset.root=..."
    )
    p.add_argument("--category", required=True, help="category to align")
    p.add_argument("--reference", default=None, help="reference instance id (default: the first instance)")
    p.add_argument("--split", default=None, help="split whose instances are aligned (default: dataset.split)")
    p.add_argument("--flip", action="store_true", help="also try the up axis turned over (8 hypotheses)")
    p.add_argument("--no-refine", action="store_true", help="score the hypotheses without ICP")
    p.add_argument(
        "--icp-distance",
        type=float,
        default=0.05,
        help="ICP correspondence distance, object-normalised unit (default 0.05)",
    )
    p.add_argument("--points", type=int, default=1024, help="surface points per shape")
    p.add_argument(
        "--low-confidence",
        type=float,
        default=0.05,
        help="rows whose confidence is below this are marked on the sheet (default 0.05)",
    )
    p.add_argument(
        "--out",
        required=True,
        help="CSV file to write (an existing one: see --force; one with rows "
        "marked verified is never overwritten: the estimate goes to <name>.new.csv)",
    )
    p.add_argument("--force", action="store_true", help="overwrite an existing --out that has no verified row")
    p.add_argument("--sheet", default=None, help="contact sheet PNG (default: the CSV's name with .png)")
    p.add_argument(
        "--draw-only",
        action="store_true",
        help="estimate nothing: redraw the sheet of the table in --out as it is (after corrections)",
    )
    p.add_argument(
        "--cues",
        choices=("auto", "ends", "none"),
        default="auto",
        help="ends: shape cues at the ends decide nose/tail, Chamfer the main axis; none: Chamfer only; "
        "auto (default): the category's (ends for airplanes, none otherwise)",
    )
    p.add_argument(
        "--compare",
        default=None,
        metavar="VERIFIED_CSV",
        help="after writing --out, compare it with this verified table (agreement, confidence ROC); "
        "writes <out>_vs_verified.csv",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command; a user error is one line on stderr and exit status 2."""
    from catpose import logs
    from catpose.errors import CatposeError

    args = build_parser().parse_args(argv)
    logs.configure("align", prefix="align.py")
    try:
        return run(args)
    except CatposeError as e:
        print(f"align.py: error: {e}", file=sys.stderr)
        return 2


def run(args: argparse.Namespace) -> int:
    check_options(args)
    outs = check_outputs(args)
    with contextlib.ExitStack() as writing:  # a read-only folder or a full disk: one line, no file half-written
        for flag in ("--out", "--sheet"):
            if flag in outs:
                writing.enter_context(outs[flag].writing())
        rows = redraw(args) if args.draw_only else align(args)
    n_low = sum(1 for r in rows if r["low"])
    print(f"wrote {len(rows)} rows to {args.out} ({n_low} marked for a closer look) and {sheet_path(args)}")
    if args.compare:
        from align_check import compare_tables, summary_line, write_comparison

        result = compare_tables(args.out, args.compare, args.category)
        with outs["--compare"].writing():
            out = write_comparison(comparison_path(args), result)
        print(f"against {args.compare}: {summary_line(result)}; rows in {out}")
    return 0


def check_options(args: argparse.Namespace) -> None:
    """Before any work: the numbers, a dataset with an alignment table, a readable ``--compare``."""
    import math

    from catpose.bench.run.config import compose
    from catpose.errors import ConfigError

    if not (math.isfinite(args.icp_distance) and args.icp_distance > 0):
        raise ConfigError(f"--icp-distance {args.icp_distance:g}: pass a distance > 0 (object-normalised, e.g. 0.05)")
    if args.points < 64:
        raise ConfigError(f"--points {args.points}: pass at least 64 surface points per shape (default 1024)")
    dataset = compose(args.overrides).dataset
    if "alignment_table" not in dataset:
        raise ConfigError(f"dataset {dataset.get('name')} has no alignment table; pass dataset=modelnet40")
    if args.compare:
        from catpose.datasets.alignment import read_alignment_table

        read_alignment_table(args.compare)  # a bad table: one line now, before --out is written


def check_outputs(args: argparse.Namespace) -> dict:
    """Before any work, where the command may write (:mod:`catpose.bench.run.overwrite`): the table
    never over verified rows (the estimate goes to ``<name>.new.csv``) nor over another table
    without ``--force``; the sheet a picture file that is no verified table's picture (unless it is
    the table's own, redrawn by ``--draw-only``) and that exists only with ``--force``; never an input.
    Returns the :class:`~catpose.bench.run.overwrite.Output` of each file written, by flag."""
    from catpose.bench.run.overwrite import Input, Output, check_not_input

    inputs = [Input(Path(args.compare), "the --compare table")] if args.compare else []
    outs = {}
    check_not_input(args.out, inputs)  # never an input, not even by way of <name>.new.csv
    if args.draw_only:
        inputs.append(Input(Path(args.out), "the --out table"))
    else:
        args.out, note = table_destination(args.out, args.force)
        outs["--out"] = Output(args.out, "file", inputs, force=True, example="category.csv")  # see table_destination
        if note:
            log.warning("%s", note)
        inputs.append(Input(Path(args.out), "the --out table"))
    sheet = sheet_path(args)
    check_sheet_suffix(sheet)
    own = Path(args.out).with_suffix(".png") if args.draw_only and not args.sheet else None
    outs["--sheet"] = Output(
        sheet, "file", inputs, args.force or own is not None, "--sheet", allow=own, example="s.png"
    )
    if args.compare:
        outs["--compare"] = Output(comparison_path(args), "file", inputs, args.force, example="x_vs_verified.csv")
    return outs


def check_sheet_suffix(path: str | Path, flag: str = "--sheet") -> None:
    """A picture's name must end in a format matplotlib writes (``SHEET_SUFFIXES``)."""
    from catpose.bench.run.overwrite import SHEET_SUFFIXES
    from catpose.errors import InvalidInputError

    if Path(path).suffix.lower() not in SHEET_SUFFIXES:
        raise InvalidInputError(
            f"{flag} {path} is not a picture file name; end it in {', '.join(SHEET_SUFFIXES)} (e.g. "
            f"{Path(path).with_suffix('.png')})"
        )


def free_name(path: Path) -> Path:
    """``<stem>.new<suffix>``, else ``<stem>.new2<suffix>``, ... : the first that does not exist."""
    k = 1
    while True:
        candidate = path.with_name(f"{path.stem}.new{'' if k == 1 else k}{path.suffix}")
        if not candidate.exists():
            return candidate
        k += 1


def table_destination(out: str | Path, force: bool = False) -> tuple[Path, str | None]:
    """Where ``align.py --out`` may write: ``(path, note)``: ``out``, or ``<name>.new.csv`` when ``out``
        has verified rows (a verified table is never overwritten); the note says why another file than
    ``out`` is written (None when it is ``out``)."""
    from catpose.bench.run.overwrite import verified_rows
    from catpose.errors import InvalidInputError

    out = Path(out)
    if not out.exists():
        return out, None
    if out.is_dir():
        raise InvalidInputError(f"--out {out} is a folder; pass the CSV file to write")
    n = verified_rows(out)
    if n:
        new = free_name(out)
        return new, (
            f"{out} has {n} row(s) marked verified, which align.py never overwrites; the new estimate "
            f"goes to {new}: compare the two and copy rows across by hand"
        )
    if not force:
        raise InvalidInputError(
            f"--out {out} exists; pass another --out, or add --force to overwrite it (it has no row marked verified)"
        )
    return out, None


def comparison_path(args: argparse.Namespace) -> Path:
    """Where ``--compare`` writes its rows: ``<out>_vs_verified.csv``."""
    return Path(args.out).with_name(Path(args.out).stem + "_vs_verified.csv")


def sheet_path(args: argparse.Namespace) -> Path:
    return Path(args.sheet) if args.sheet else Path(args.out).with_suffix(".png")


def load_clouds(args: argparse.Namespace) -> tuple[str, list[str], str, list]:
    """(dataset name, instance ids, reference id, raw-frame normalised clouds (M, 3) per id)."""
    import numpy as np

    from catpose.bench.category.template_medoids import instance_ids
    from catpose.bench.run.config import compose_and_build
    from catpose.errors import ConfigError, DatasetError

    overrides = list(args.overrides)
    # the raw frames are what is estimated: no table, not declared aligned
    overrides += ["dataset.alignment_table=null", "dataset.aligned=false", f"dataset.template_points={args.points}"]
    _, ((name, ds),) = compose_and_build(overrides, ("dataset",))
    ids = instance_ids(ds, args.category, args.split)
    if len(ids) < 2:
        raise DatasetError(
            f"dataset {name} has {len(ids)} instances of {args.category!r}; alignment needs at "
            "least 2 (check --category, --split and dataset.root)"
        )
    ref = args.reference or ids[0]
    if ref not in ids:
        raise ConfigError(f"--reference {ref} is not among the {len(ids)} {args.category} instances ({ids[0]}, ...)")
    return name, ids, ref, [np.asarray(ds.instance_model(args.category, i).points, float) for i in ids]


def redraw(args: argparse.Namespace) -> list[dict]:
    """The sheet of the table in ``args.out`` as it stands (rows titled red unless verified)."""
    import csv

    from catpose.datasets.alignment import read_alignment_table
    from catpose.errors import DatasetError

    table = read_alignment_table(args.out)
    with open(args.out, newline="") as fh:
        meta = {(r["category"], r["instance_id"]): r for r in csv.DictReader(fh)}
    name, ids, ref, clouds = load_clouds(args)
    missing = [i for i in ids if (args.category, i) not in table]
    if missing:
        raise DatasetError(f"{args.out} has no rows for {missing[:3]}; run align.py without --draw-only")
    rows = []
    for i in ids:
        m = meta[(args.category, i)]
        verified = str(m.get("verified", "")).strip().lower() == "true"
        conf = float(m["confidence"]) if (m.get("confidence") or "").strip() else float("nan")
        rows.append({"instance_id": i, "R": table[(args.category, i)], "confidence": conf, "low": not verified})
    n_ok = sum(not r["low"] for r in rows)
    draw_contact_sheet(
        sheet_path(args),
        ids,
        clouds,
        ids.index(ref),
        [r["R"] for r in rows],
        [r["confidence"] for r in rows],
        [r["low"] for r in rows],
        f"{name} {args.category}: table {Path(args.out).name} ({n_ok}/{len(rows)} verified), reference {ref} (grey)",
    )
    return rows


def align(args: argparse.Namespace) -> list[dict]:
    from alignment_estimate import estimate_table, resolve_cues, write_alignment_table, yaw_flip_hypotheses

    from catpose.datasets.alignment import yaw_deg_of

    name, ids, ref, clouds = load_clouds(args)
    hyps = yaw_flip_hypotheses(args.flip)
    est = estimate_table(
        clouds,
        hyps,
        reference=ids.index(ref),
        refine=not args.no_refine,
        max_distance=args.icp_distance,
        cues=resolve_cues(args.cues, args.category),
    )
    rows = []
    for k, instance_id in enumerate(ids):
        a = int(est["labels"][k])
        R = hyps[a]
        disagree = a != int(est["labels_reference"][k])
        low = bool(est["confidence"][k] < args.low_confidence or disagree)
        rows.append(
            {
                "category": args.category,
                "instance_id": instance_id,
                "R": R,
                "yaw_deg": float(round((a % 4) * 90.0)),
                "flip": a >= 4,
                "chamfer": float(est["chamfer"][k]),
                "confidence": float(est["confidence"][k]),
                "verified": False,
                "note": "consensus differs from the reference-only estimate" if disagree else "",
                "low": low,
            }
        )
        log.info(
            "%s/%s: yaw %d%s, chamfer %.4f, confidence %.3f%s",
            args.category,
            instance_id,
            (a % 4) * 90,
            " flip" if a >= 4 else "",
            est["chamfer"][k],
            est["confidence"][k],
            "  <- check" if low else "",
        )
    assert all(yaw_deg_of(r["R"]) is not None or r["flip"] for r in rows)
    write_alignment_table(args.out, rows)
    draw_contact_sheet(
        sheet_path(args),
        ids,
        clouds,
        ids.index(ref),
        [r["R"] for r in rows],
        [r["confidence"] for r in rows],
        [r["low"] for r in rows],
        f"{name} {args.category}: estimated alignment to {ref} (grey)",
    )
    return rows


def draw_contact_sheet(
    path: str | Path,
    ids: list[str],
    clouds: list,
    reference: int,
    R_ref_instance: list,
    confidence: list[float],
    low: list[bool],
    title: str,
    per_row: int = 2,
    max_points: int = 700,
) -> Path:
    """A PNG grid: per instance, its cloud turned by ``R_ref_instance`` (3, 3) over the reference's
    (grey) in three views: top (x right, y up), side (x right, z up) and side (y right, z up),
    coloured by height (z); ``low`` rows titled in red."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    def thin(p: np.ndarray) -> np.ndarray:
        return p[:: max(1, len(p) // max_points)]

    n = len(ids)
    rows = (n + per_row - 1) // per_row
    fig, axes = plt.subplots(rows, 3 * per_row, figsize=(3 * per_row * 2.0, rows * 2.1), squeeze=False)
    ref = thin(clouds[reference])
    for ax in axes.ravel():
        ax.set_axis_off()
    for k in range(n):
        p = thin(clouds[k]) @ np.asarray(R_ref_instance[k]).T
        for v, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))):
            ax = axes[k // per_row, 3 * (k % per_row) + v]
            ax.scatter(ref[:, a], ref[:, b], s=0.6, c="0.6", linewidths=0)
            # coloured by height: a tail fin or a chair back stands out, so direction can be judged
            ax.scatter(p[:, a], p[:, b], s=0.6, c=p[:, 2], cmap="viridis", vmin=-0.8, vmax=0.8, linewidths=0)
            ax.set_xlim(-1, 1)
            ax.set_ylim(-1, 1)
            ax.set_aspect("equal")
            ax.set_axis_on()
            ax.set_xticks([])
            ax.set_yticks([])
            if v == 0:
                ax.set_title(
                    f"{ids[k]} c={confidence[k]:.2f}" + (" CHECK" if low[k] else ""),
                    fontsize=6.5,
                    loc="left",
                    color="red" if low[k] else "black",
                )
            else:
                ax.set_title(("side x,z", "side y,z")[v - 1], fontsize=5.5, loc="right", color="0.4")
    fig.suptitle(title + "  [top x,y | side x,z | side y,z; colour: height; red title: check]", fontsize=7)
    fig.tight_layout(pad=0.3, h_pad=0.4, w_pad=0.2, rect=(0, 0, 1, 1 - 0.3 / fig.get_figheight()))
    from catpose import atomic

    path = Path(path)
    with atomic.atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=75)
    plt.close(fig)
    return path


if __name__ == "__main__":
    raise SystemExit(main())
