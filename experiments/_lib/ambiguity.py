"""Why a wrong estimate won: a search miss, or a pose the depth image cannot tell from the truth.

For every wrong registration (``err_deg >= wrong_deg``, failed samples left out) of finished
``gt_model`` or ``templates`` runs on data with depth images (with category templates every
registration of a view is judged, the template at the truth against the template at its
estimate), the sample's template is rendered at the estimate and at the ground truth and both are
scored with ours' occlusion-aware depth check (:class:`catpose.methods.ours.check.DepthVerifier`,
with the settings of ours' final comparison read from the run's config).

The estimate has been refined by ours; the annotated truth has not, and real annotations are a
few millimetres off the depth image. So the truth is also refined the way ours refines its last
poses (:func:`catpose.methods.ours.refine.refine_poses`, on every input point) and the truth's cost
is the lower of the two:

- **ambiguous**: the estimate explains the image at least as well as the truth
  (``cost(estimate) <= min(cost(truth), cost(refined truth))``). No search fixes it under this
  verifier: it needs another cue (colour, a finer verifier), or the object is (nearly) symmetric
  in that view;
- **search miss**: the truth explains the image better, but ours did not find or keep it.

A wrong estimate at least ``FLIP_DEG`` from the truth is also counted as a flip (a half turn of
a near-symmetric shape).

Ground truth is read here for diagnosis only, never by a method. Rows are grouped by object
(BOP ``obj_id``, else the category) and, where the run's dataset has a split
(``configs/split/<name>.yaml``), by its part, so that figures of the scenes a default was chosen on
stay apart from the others.

    python experiments/_lib/ambiguity.py RUN_DIR [RUN_DIR ...] --out results/ambiguity/table.md [--split clutter]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from catpose.bench.scoring.metrics import FOUND_DEG
from catpose.errors import CatposeError, ConfigError

#: an estimate at least this far (degrees, the run's ``err_deg``) from the truth is wrong
WRONG_DEG = 10.0
#: a wrong estimate at least this far from the truth is counted as a flip (a half turn)
FLIP_DEG = 150.0


def _run_parts(run_dir: Path):
    """(method settings for the verifier, dataset, protocol) rebuilt from a run's ``config.yaml``."""
    from omegaconf import OmegaConf

    from catpose.bench.run.build import build_dataset, build_from_config, build_protocol
    from catpose.bench.run.run_meta import read_config
    from catpose.methods.ours.settings import SelectionSettings

    cfg = OmegaConf.create(read_config(run_dir, required=True))
    if str(cfg.protocol.name) not in ("gt_model", "templates"):
        raise ConfigError(
            f"run {run_dir}: protocol {cfg.protocol.name!r}; this check needs a protocol=gt_model "
            "or protocol=templates run"
        )
    sel = SelectionSettings()
    if "selection" in cfg.method:
        sel = build_from_config(cfg.method.selection, "method.selection")[1]
    return sel, build_dataset(cfg.dataset), build_protocol(cfg)


def verifier_costs(sel, problem, T_est: np.ndarray, T_gt: np.ndarray) -> tuple[float, float, float]:
    """Depth-check costs (lower is better) of the estimate, the truth and the refined truth
    (:func:`refined_truth`), (4, 4) ``T_template_camera`` each, on the lattice of ours' final
    comparison (``sel``: :class:`SelectionSettings`)."""
    from catpose.methods.ours.check import final_verifier

    est, gt, gt_refined = final_verifier(sel, problem).scores(
        np.stack([T_est, T_gt, refined_truth(sel, problem, T_gt)])
    )
    return float(est), float(gt), float(gt_refined)


def refined_truth(sel, problem, T_gt: np.ndarray) -> np.ndarray:
    """``T_gt`` (4, 4) ``T_template_camera`` refined as ours refines its last poses
    (:func:`catpose.methods.ours.refine.refine_poses`) on every input point; ``T_gt`` itself with
    ``sel.refine`` off."""
    from catpose import cell_grid
    from catpose.methods.ours.refine import REFINE_MAX_DISTANCE, refine_poses

    if not sel.refine:
        return np.asarray(T_gt, float)
    tpl = problem.template
    grid = cell_grid.build(tpl.points, REFINE_MAX_DISTANCE)
    return refine_poses(problem.points_camera, grid, tpl.normals, np.asarray(T_gt, float)[None])[0]


def wrong_rows(run_dir: Path, wrong_deg: float = WRONG_DEG) -> tuple[list[dict], int]:
    """One row per wrong sample of ``run_dir`` (see the module doc) and the number of samples
    judged (ok rows)."""
    from catpose.bench.run.evaluate import recompute_row_errors
    from catpose.bench.run.rundir import latest_rows

    sel, dataset, protocol = _run_parts(run_dir)
    rows = [recompute_row_errors(r) for r in latest_rows(Path(run_dir) / "samples.jsonl") if r.get("status") == "ok"]
    out = []
    for r in rows:
        if float(r["err_deg"]) < wrong_deg:
            out.append({"sample_id": r["sample_id"], "object": _object(r), "wrong": False, "obj_id": _obj_id(r)})
            continue
        sample = protocol.load(dataset, r["sample_id"])
        if sample.problem.depth_image is None:
            raise ConfigError(
                f"run {run_dir}: sample {r['sample_id']} has no depth image; this check needs "
                "data with depth images (BOP, clutter, the renderer); for point clouds of a "
                "templates run use python experiments/_lib/why_wrong.py"
            )
        T_est = np.asarray(r["T_est"], float).reshape(4, 4)
        est, gt, gt_refined = verifier_costs(sel, sample.problem, T_est, np.asarray(sample.gt.T_template_camera, float))
        out.append(
            {
                "sample_id": r["sample_id"],
                "object": _object(r),
                "obj_id": _obj_id(r),
                "wrong": True,
                "err_deg": float(r["err_deg"]),
                "cost_est": est,
                "cost_gt": gt,
                "cost_gt_refined": gt_refined,
                "ambiguous": bool(est <= min(gt, gt_refined)),
                "found": None if r.get("found_err_deg") is None else bool(float(r["found_err_deg"]) < FOUND_DEG),
            }
        )
    return out, len(rows)


def _obj_id(row: dict) -> int:
    return int((row.get("info") or {}).get("obj_id", -1))


def _object(row: dict) -> str:
    info = row.get("info") or {}
    return f"obj {int(info['obj_id'])}" if info.get("obj_id") is not None else str(row.get("category"))


def table(rows: list[dict], part_of) -> list[dict]:
    """Per (part, object) and per part overall: samples, wrong, flips (at least ``FLIP_DEG``),
    ambiguous, search misses, and the median cost of the truth, the refined truth and the estimate
    over the wrong samples."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        part = part_of(r)
        groups.setdefault((part, r["object"]), []).append(r)
        groups.setdefault((part, "all"), []).append(r)
    out = []

    def order(key: tuple[str, str]) -> tuple:
        part, obj = key
        number = obj.split()[-1]
        return part, obj == "all", int(number) if obj.startswith("obj ") and number.isdigit() else -1, obj

    for (part, obj), g in sorted(groups.items(), key=lambda kv: order(kv[0])):
        wrong = [r for r in g if r["wrong"]]
        amb = [r for r in wrong if r["ambiguous"]]

        def median(key: str) -> float:
            return float(np.median([r[key] for r in wrong])) if wrong else float("nan")

        out.append(
            {
                "part": part,
                "object": obj,
                "samples": len(g),
                "wrong": len(wrong),
                "flips": sum(r["err_deg"] >= FLIP_DEG for r in wrong),
                "ambiguous": len(amb),
                "search_miss": len(wrong) - len(amb),
                "found_not_chosen": (
                    None if any(r.get("found") is None for r in wrong) else sum(bool(r["found"]) for r in wrong)
                ),
                "median_cost_gt": median("cost_gt"),
                "median_cost_gt_refined": median("cost_gt_refined"),
                "median_cost_est": median("cost_est"),
            }
        )
    return out


def markdown(title: str, rows: list[dict]) -> str:
    head = [
        "part",
        "object",
        "samples",
        "wrong (>= 10 deg)",
        f"of them flips (>= {FLIP_DEG:g} deg)",
        "ambiguous",
        "search miss",
        "found, not chosen",
        "median cost truth",
        "median cost truth refined",
        "median cost estimate",
    ]
    lines = [f"**{title}**", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [
            r["part"],
            r["object"],
            r["samples"],
            r["wrong"],
            r["flips"],
            r["ambiguous"],
            r["search_miss"],
            "-" if r["found_not_chosen"] is None else r["found_not_chosen"],
            f"{r['median_cost_gt']:.3f}",
            f"{r['median_cost_gt_refined']:.3f}",
            f"{r['median_cost_est']:.3f}",
        ]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    lines += [
        "",
        "ambiguous: the wrong estimate's depth-check cost is at most the truth's, the truth as annotated "
        "or refined by ours' ICP, whichever costs less (the image cannot tell them apart under ours' "
        "verifier); search miss: the truth's cost is lower. found, not chosen: ours held a hypothesis "
        f"within {FOUND_DEG:g} deg of the truth at some stage of its search (the rest were never found; "
        "- : the run stored no hypothesis recall).",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    from catpose import atomic
    from catpose.bench.real.split import load_split

    parser = argparse.ArgumentParser(
        prog="python experiments/_lib/ambiguity.py",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("runs", nargs="+", type=Path, help="gt_model run directories (their rows are pooled)")
    parser.add_argument("--out", type=Path, required=True, help="Markdown table to write (a .csv is written beside it)")
    parser.add_argument("--split", help="configs/split/<name>.yaml: one block of rows per part")
    parser.add_argument("--title", default="Wrong estimates: search miss or ambiguous to the depth check")
    parser.add_argument("--wrong-deg", type=float, default=WRONG_DEG)
    parser.add_argument("--force", action="store_true", help="replace an existing --out (and the .csv beside it)")
    args = parser.parse_args(argv)
    try:
        from catpose.bench.run.overwrite import Output, input_runs

        # the one output rule, before any work (docs/file-safety.md)
        md, csv = (
            Output(p, "file", input_runs(args.runs), args.force) for p in (args.out, args.out.with_suffix(".csv"))
        )
        split = load_split(args.split) if args.split else None
        rows: list[dict] = []
        for run in args.runs:
            rows += wrong_rows(run, args.wrong_deg)[0]
        if not rows:
            raise ConfigError(f"no finished samples in {', '.join(map(str, args.runs))}; run them first")

        def part_of(row: dict) -> str:
            if split is None:
                return "all"
            obj_of = {row["sample_id"]: row["obj_id"]}
            return next((p for p in split.parts if split.sample_ids(p, [row["sample_id"]], obj_of)), "other")

        summary = table(rows, part_of)
        import pandas as pd

        with md.writing() as md_path, csv.writing() as csv_path:
            atomic.write_text(csv_path, pd.DataFrame(summary).to_csv(index=False, float_format="%.4f"))
            atomic.write_text(md_path, markdown(args.title, summary))
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
