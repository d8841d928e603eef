"""Why a category-level view's kept estimate is wrong, at each step that chose it
(``python experiments/_lib/why_wrong.py RUN_OR_SWEEP --row ours --out why.md``).

A ``templates`` run keeps, per view, one estimate: a registration on one of the K templates, and
under the ``cross`` rules (:mod:`catpose.methods.choice_rules`) that registration or one
of its turns, perhaps averaged with the other templates' agreeing poses. Every view whose kept
estimate is at least ``WRONG_DEG`` from the truth gets a row. One between ``WRONG_DEG`` and
``NEAR_DEG`` is ``imprecise``: in the truth's basin, pulled off by a template that is another
instance. For the others two questions are asked of the cost that made each choice, with the
truth's basin (the poses within ``NEAR_DEG`` of the truth) put in the estimate's place:

1. **The registration** on the kept template (``ours`` runs on point clouds: ours' own point rule,
   ``selection.rule`` or its ``depth_fallback``, the visibility-aware Chamfer score with which ours
   chose among its candidates; where ours chose by the depth check, ``experiments/_lib/ambiguity.py``
   asks this question of depth images). Its own estimate and the truth are scored, and so is every pose ours'
   refinement (point-to-plane ICP on the Chamfer points, then on every input point) reaches inside
   the basin from the truth, from the truth nudged by ``NUDGE_DEG`` about each template axis, and
   from each of ours' candidates or their half turns inside the basin; the lowest of those is the
   refined truth:

   - ``right``: the registration's own estimate is within ``WRONG_DEG`` (the choice moved away from it);
   - ``ambiguous``: the estimate scores at most what the truth and the refined truth do: the
     template, a different instance than the one seen, fits the wrong pose at least as well, and no
     search or selection fixes that under this score;
   - ``not kept``: the refined truth scores lower and one of ours' candidates or their half turns
     (what its selection compares) lies inside the basin: the search reached it, the selection did
     not keep it;
   - ``not found``: the refined truth scores lower and no candidate lies inside the basin.

2. **The choice** among the K templates' registrations and their turns (the ``cross`` rules, from the
   costs the run stored). The kept candidate's rule cost (before ``fused`` averages it) is set
   against the truth's, on each template as given and after the cross check's ICP
   (:meth:`~catpose.methods.cross_check.CrossCheck.refine_on`, the run's ``choice`` settings), the
   lowest over the templates:

   - ``ambiguous``: the kept candidate costs at most the truth: the rule prefers the wrong pose;
   - ``missed``: the truth costs less; no candidate the rule chose among stood near enough
     (``rule_nearest_deg`` is the closest one's angle to the truth).

Ground truth is read for this diagnosis only, never by a method or a rule. The figures come from the
run's files and the code the run used, recomputed here (ours' candidates are deterministic).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from catpose.errors import CatposeError, ConfigError

#: a kept estimate at least this far (degrees, the view's ``err_deg``) from the truth is wrong
WRONG_DEG = 10.0
#: poses within this (degrees) of the truth are in its basin (the @30 accuracy's threshold): a kept
#: estimate between ``WRONG_DEG`` and this is ``imprecise``, the others are judged against the basin
NEAR_DEG = 30.0
#: the truth is also nudged by this (degrees) either way about each template axis before refinement
NUDGE_DEG = 5.0


def run_dirs(paths: list[Path], row: str, overrides: tuple[str, ...] = ()) -> list[Path]:
    """Run directories: each path that holds a ``config.yaml``, and the jobs of each sweep
    directory among ``paths`` whose overrides hold ``+row=<row>`` and every one of ``overrides``
    (``key=value`` as the sweep wrote them, e.g. ``method.selection.top_k=18``)."""
    from catpose.bench.run.sweep import read_sweep

    wanted = {f"+row={row}", *overrides}
    out = []
    for p in map(Path, paths):
        if (p / "config.yaml").is_file():
            out.append(p)
            continue
        jobs = [j for j in read_sweep(p) if wanted <= set(j.get("overrides", [])) and j.get("run_dir")]
        if not jobs:
            raise ConfigError(
                f"{p} is neither a run directory (no config.yaml) nor a sweep with a finished job of "
                f"{' '.join(sorted(wanted))}; pass a `bench run` folder or a `bench run -m` sweep folder"
            )
        out += [Path(j["run_dir"]) for j in jobs]
    return out


def registration_costs(ours: Any, problem: Any, T_est: np.ndarray, T_gt: np.ndarray) -> dict:
    """Ours' point-rule score (lower is better, object-normalised unit) on ``problem``'s template of
    the estimate ``T_est`` and the truth ``T_gt`` ((4, 4) ``T_template_camera`` each); the lowest
    score of the poses ours' refinement reaches, still within ``NEAR_DEG`` of the truth, from the
    truth, the truth nudged by ``NUDGE_DEG`` either way about each template axis, and each of ours'
    candidates or their half turns within ``NEAR_DEG`` of the truth (``cost_truth_refined``; inf
    when none stays near); and the angle (degrees) from the truth to the nearest of those
    candidates. ``ours``: a :class:`~catpose.methods.ours.Ours`."""
    from catpose import cell_grid
    from catpose.methods.choice_rules import rotation_angle_deg
    from catpose.methods.cross_check import turned
    from catpose.methods.ours.point_choice import VISIBILITY_TRUNC, chamfer_distances
    from catpose.methods.ours.refine import refine_poses
    from catpose.methods.pose_scores import half_turns
    from catpose.methods.pose_scores_kernel import visibility_scores

    sel = ours.point_selection
    if sel.rule not in ("visibility", "chamfer"):
        raise ConfigError(
            f"method.selection.rule={sel.rule!r} scores no pose but its own candidates; this check "
            "needs ours' visibility or chamfer rule"
        )
    c = ours.candidates(problem)
    feats = ours.template_features(problem.template)
    normals = problem.template.normals
    src = c.chamfer_src
    if sel.rule == "visibility":
        grid = cell_grid.build(src, VISIBILITY_TRUNC)

        def score(T: np.ndarray) -> np.ndarray:
            return visibility_scores(src, grid, T, feats.truncated, normals, VISIBILITY_TRUNC)
    else:

        def score(T: np.ndarray) -> np.ndarray:
            return chamfer_distances(feats.tree, src, T)

    T_gt = np.asarray(T_gt, float)
    near = [F @ T for T in c.T for F in half_turns()]
    nearest = min(rotation_angle_deg(T[:3, :3], T_gt[:3, :3]) for T in near)
    # where ours' refinement goes from the truth, from the truth nudged by NUDGE_DEG about each axis, and
    # from each of its own candidates (half turns too) that came within NEAR_DEG of the truth
    starts = [T_gt] + [turned(T_gt, np.eye(3)[axis], sign * NUDGE_DEG) for axis in range(3) for sign in (-1, 1)]
    starts += [T for T in near if rotation_angle_deg(T[:3, :3], T_gt[:3, :3]) < NEAR_DEG]
    T_ref = np.stack(starts)
    if sel.refine:  # as ours refines a candidate (Chamfer points), then its winner (every input point)
        for points in (src, c.points):
            T_ref = refine_poses(points, feats.pairing, normals, T_ref)
    still_near = [rotation_angle_deg(T[:3, :3], T_gt[:3, :3]) < NEAR_DEG for T in T_ref]
    est, gt = score(np.stack([np.asarray(T_est, float), T_gt]))
    refined = score(T_ref)
    return {
        "cost_estimate": float(est),
        "cost_truth": float(gt),
        "cost_truth_refined": float(np.min(np.where(still_near, refined, np.inf))),
        "nearest_candidate_deg": float(nearest),
    }


def registration_verdict(err_deg: float, costs: dict, wrong_deg: float = WRONG_DEG) -> str:
    """``right``, ``imprecise``, ``ambiguous``, ``not kept`` or ``not found`` (module doc, step 1) of
    one registration whose own error is ``err_deg`` and whose :func:`registration_costs` are ``costs``."""
    if err_deg < wrong_deg:
        return "right"
    if err_deg < NEAR_DEG:
        return "imprecise"
    if costs["cost_estimate"] <= min(costs["cost_truth"], costs["cost_truth_refined"]):
        return "ambiguous"
    return "not kept" if costs["nearest_candidate_deg"] < NEAR_DEG else "not found"


def rule_poses(group, rule: Any) -> list[tuple[float, int, np.ndarray]]:
    """(cost, own template index, pose (4, 4)) of every candidate ``rule`` (a ``cross`` rule's
    :class:`~catpose.methods.choice_rules.ChoiceRule`) chose among in one view's rows ``group``:
    the registrations, and their turns under the turn rules."""
    from catpose.bench.protocols.absolute import estimates_of
    from catpose.methods.choice_rules import TURN_RULES, cross_costs_of, turn_candidates_of

    estimates = estimates_of(group)
    if rule.rule in TURN_RULES:
        return [
            (key[0], own, np.asarray(T, float).reshape(4, 4))
            for key, own, T in turn_candidates_of(estimates, rule.cross_weight, rule.offset_weight, rule.rule)
        ]
    costs = cross_costs_of(estimates, rule.cross_weight, rule.offset_weight)
    return [
        (float(c), e.template_index, np.asarray(e.T_template_camera, float).reshape(4, 4))
        for c, e in zip(costs, estimates)
        if e.ok and np.isfinite(c)
    ]


def choice_costs(
    points_camera: np.ndarray, templates: list, T_gts: list[np.ndarray], poses: list, rule: Any, check: Any
) -> dict:
    """The kept candidate's rule cost (the lowest of ``poses``, :func:`rule_poses`) and the truth's
    (the lowest over the K ``templates``, each at its ``T_gts[k]`` (4, 4) as given and after the cross
    check's ICP), with the template index of that lowest and the angle (degrees) from the truth to
    the nearest candidate. ``points_camera``: the view (N, 3); ``rule``: the
    :class:`~catpose.methods.choice_rules.ChoiceRule`, ``check``: the run's
    :class:`~catpose.methods.cross_check.CrossCheck`."""
    from catpose.methods.choice_rules import cross_cost, rotation_angle_deg

    top_weight = rule.offset_weight or 0.0
    P = np.asarray(points_camera, float)
    truth = []
    for k, (template, T_gt) in enumerate(zip(templates, T_gts)):
        T_gt = np.asarray(T_gt, float)
        for T in (T_gt, check.refine_on(P, template, np.round(T_gt, 9))):
            truth.append(
                (
                    cross_cost(
                        check.cross_costs(P, T, templates, k),
                        k,
                        rule.cross_weight,
                        check.top_offset(P, T, templates, k),
                        top_weight,
                    ),
                    k,
                )
            )
    best_truth = min(truth)
    nearest = min(rotation_angle_deg(T[:3, :3], np.asarray(T_gts[own], float)[:3, :3]) for _, own, T in poses)
    return {
        "rule_cost_kept": float(min(c for c, _, _ in poses)),
        "rule_cost_truth": float(best_truth[0]),
        "rule_truth_template": int(best_truth[1]),
        "rule_nearest_deg": float(nearest),
    }


def choice_verdict(err_deg: float, costs: dict) -> str:
    """``imprecise``, ``ambiguous`` or ``missed`` (module doc, step 2) of a kept estimate whose error
    is ``err_deg`` (at least ``WRONG_DEG``) and whose :func:`choice_costs` are ``costs``."""
    if err_deg < NEAR_DEG:
        return "imprecise"
    return "ambiguous" if costs["rule_cost_kept"] <= costs["rule_cost_truth"] else "missed"


def _run_parts(run_dir: Path):
    """(method name, method, dataset, protocol, cross check) rebuilt from a templates run's ``config.yaml``."""
    from omegaconf import OmegaConf

    from catpose.bench.run.build import build_choice, build_parts
    from catpose.bench.run.run_meta import read_config

    cfg = OmegaConf.create(read_config(run_dir, required=True))
    if str(cfg.protocol.name) != "templates":
        raise ConfigError(f"run {run_dir}: protocol {cfg.protocol.name!r}; this check needs a protocol=templates run")
    return (*build_parts(cfg), build_choice(cfg).cross_check)


def why_rows(run_dir: Path, choice: str | None = None, wrong_deg: float = WRONG_DEG) -> tuple[list[dict], int]:
    """One row per view of ``run_dir`` whose kept estimate (under the run's ``choice`` rule, or the
    rule ``choice`` with the run's weights) is wrong: its errors, the kept template and turn, step 1 (``ours`` runs) and step 2
    (``cross`` rules) of the module doc; and how many views the run holds."""
    import dataclasses

    import pandas as pd

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from category_table import has_turns  # the sibling script (experiments/_lib/category_table.py)

    from catpose.bench.run.evaluate import recompute_row_errors
    from catpose.bench.run.rundir import latest_rows
    from catpose.methods.choice_rules import CROSS_RULES, check_rule
    from catpose.methods.ours import Ours

    method_name, method, dataset, protocol, check = _run_parts(run_dir)
    if choice is not None:
        protocol.choice = dataclasses.replace(protocol.choice, rule=check_rule(choice))
    rule = protocol.choice
    rows = [recompute_row_errors(r) for r in latest_rows(Path(run_dir) / "samples.jsonl")]
    if not rows:
        raise ConfigError(f"run {run_dir} has no finished samples; run it first")
    frame = pd.DataFrame(rows)
    units = protocol.score_units(frame)
    out = []
    for kept in units.to_dict("records"):
        if kept.get("status") != "ok" or float(kept["err_deg"]) < wrong_deg:
            continue
        group = frame[frame["group_id"] == kept["group_id"]]
        own = frame[frame["sample_id"] == kept["sample_id"]].iloc[0]
        info = kept.get("info") if isinstance(kept.get("info"), dict) else {}
        r = {
            "view": kept["group_id"],
            "template_id": kept.get("template_id"),
            "err_deg": float(kept["err_deg"]),
            "oracle_err_deg": float(kept["oracle_err_deg"]),
            "turn_deg": info.get("turn_deg", ""),
            "fused_templates": info.get("fused_templates", ""),
            "method": method_name,
            "registration_err_deg": float(own["err_deg"]),
        }
        # the view against each of its templates, in template order (the kept one among them)
        loaded = {sid: protocol.load(dataset, sid) for sid in sorted(group["sample_id"], key=_template_index)}
        sample = loaded[kept["sample_id"]]
        if isinstance(method, Ours) and not method.uses_depth(sample.problem):  # depth: experiments/_lib/ambiguity.py
            costs = registration_costs(
                method, sample.problem, np.reshape(own["T_est"], (4, 4)), sample.gt.T_template_camera
            )
            r.update(costs, registration=registration_verdict(r["registration_err_deg"], costs, wrong_deg))
        else:
            r["registration"] = "-"
        if rule.rule in CROSS_RULES and (len(group) > 1 or has_turns(group)):
            poses = rule_poses(group, rule)
            if poses:
                views = list(loaded.values())
                c = choice_costs(
                    sample.problem.points_camera,
                    [v.problem.template for v in views],
                    [v.gt.T_template_camera for v in views],
                    poses,
                    rule,
                    check,
                )
                c["rule_truth_template"] = views[c["rule_truth_template"]].problem.template.template_id
                r.update(c, choice=rule.rule, choice_verdict=choice_verdict(r["err_deg"], c))
        r.setdefault("choice", rule.rule if len(group) > 1 else "-")
        r.setdefault("choice_verdict", "-")
        out.append(r)
    return sorted(out, key=lambda r: r["view"]), len(units)


def _template_index(sample_id: str) -> int:
    from catpose.bench.protocols.absolute import split_template_sample_id

    return split_template_sample_id(sample_id)[1]


COLUMNS = [
    "view",
    "method",
    "template_id",
    "err_deg",
    "oracle_err_deg",
    "turn_deg",
    "fused_templates",
    "registration_err_deg",
    "cost_estimate",
    "cost_truth",
    "cost_truth_refined",
    "nearest_candidate_deg",
    "registration",
    "choice",
    "rule_cost_kept",
    "rule_cost_truth",
    "rule_truth_template",
    "rule_nearest_deg",
    "choice_verdict",
]


def markdown(title: str, rows: list[dict], views: int, wrong_deg: float = WRONG_DEG) -> str:
    """The rows as a Markdown table under ``title`` (``views``: how many views the runs hold,
    ``wrong_deg``: the threshold they were judged at), with the counts of each verdict."""

    def f(v: Any, fmt: str = ".3f") -> str:
        return (
            "-"
            if v is None or v == "" or (isinstance(v, float) and not np.isfinite(v))
            else (format(v, fmt) if isinstance(v, float) else str(v))
        )

    head = [
        "view",
        "kept template",
        "error",
        "oracle",
        "turn",
        "registration error",
        "registration",
        "score estimate / truth / truth refined",
        "nearest candidate",
        "choice",
        "rule cost kept / truth (template)",
        "nearest rule candidate",
    ]
    lines = [
        f"**{title}**",
        "",
        f"{len(rows)} of {views} views kept an estimate {wrong_deg:g} degrees or more from the truth.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in rows:
        scores = (
            " / ".join(f(r.get(k), ".4f") for k in ("cost_estimate", "cost_truth", "cost_truth_refined"))
            if "cost_estimate" in r
            else "-"
        )
        rule = (
            (
                f"{f(r.get('rule_cost_kept'), '.4f')} / {f(r.get('rule_cost_truth'), '.4f')} "
                f"({str(r.get('rule_truth_template')).rsplit('/', 1)[-1]})"
            )
            if "rule_cost_kept" in r
            else "-"
        )
        lines.append(
            "| "
            + " | ".join(
                [
                    r["view"],
                    str(r["template_id"]).rsplit("/", 1)[-1],
                    f(r["err_deg"], ".2f"),
                    f(r["oracle_err_deg"], ".2f"),
                    f(r["turn_deg"], "g"),
                    f(r["registration_err_deg"], ".2f"),
                    r["registration"],
                    scores,
                    f(r.get("nearest_candidate_deg"), ".1f"),
                    f"{r['choice']}: {r['choice_verdict']}" if r["choice_verdict"] != "-" else r["choice"],
                    rule,
                    f(r.get("rule_nearest_deg"), ".1f"),
                ]
            )
            + " |"
        )
    counts = {}
    for key in ("registration", "choice_verdict"):
        for r in rows:
            if r[key] != "-":
                counts[(key, r[key])] = counts.get((key, r[key]), 0) + 1
    if counts:
        lines += [
            "",
            "Verdicts: "
            + "; ".join(
                f"{'registration' if k == 'registration' else 'choice'} {v}: {n}"
                for (k, v), n in sorted(counts.items())
            ),
        ]
    lines += [
        "",
        f"imprecise: {wrong_deg:g} to {NEAR_DEG:g} degrees off, in the truth's basin. registration (ours' "
        "own selection score on the kept template, lower is better): right, its own estimate was within "
        f"{wrong_deg:g} degrees; ambiguous, the estimate scores at most the truth's, as given or refined inside "
        f"the basin ({NEAR_DEG:g} degrees); not kept, the refined truth scores lower and one of ours' candidates "
        "lay inside the basin; not found, none did. choice (the rule's cost over the K templates): ambiguous, "
        "the kept candidate costs at most the truth's lowest; missed, the truth costs less. Angles in degrees; "
        'scores in the object-normalised unit (docs/category-level.md, "Why a view is wrong").',
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    from catpose import atomic

    parser = argparse.ArgumentParser(
        prog="python experiments/_lib/why_wrong.py",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("runs", nargs="+", type=Path, help="templates run directories or `bench run -m` sweep folders")
    parser.add_argument(
        "--row", default="ours", help="in a sweep folder, the +row of the jobs to judge (default: ours)"
    )
    parser.add_argument(
        "--override",
        action="append",
        default=[],
        help="in a sweep folder, judge only the jobs with this override too (key=value; repeatable)",
    )
    parser.add_argument("--out", type=Path, required=True, help="Markdown table to write (a .csv is written beside it)")
    parser.add_argument(
        "--choice", help="judge the choice of this choice rule, with the run's weights (default: the run's rule)"
    )
    parser.add_argument("--title", default="Why each wrong view is wrong")
    parser.add_argument("--wrong-deg", type=float, default=WRONG_DEG)
    parser.add_argument("--force", action="store_true", help="replace an existing --out (and the .csv beside it)")
    args = parser.parse_args(argv)
    try:
        from catpose.bench.run.overwrite import Output, input_runs

        # the one output rule, before any work (docs/file-safety.md)
        md, csv = (
            Output(p, "file", input_runs(args.runs), args.force) for p in (args.out, args.out.with_suffix(".csv"))
        )
        import pandas as pd

        rows: list[dict] = []
        views = 0
        for run in run_dirs(args.runs, args.row, tuple(args.override)):
            judged, n = why_rows(run, args.choice, args.wrong_deg)
            rows += judged
            views += n
        with md.writing() as md_path, csv.writing() as csv_path:
            atomic.write_text(csv_path, pd.DataFrame(rows, columns=COLUMNS).to_csv(index=False, float_format="%.4f"))
            atomic.write_text(md_path, markdown(args.title, rows, views, args.wrong_deg))
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
