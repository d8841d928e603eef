"""PPF's settings chosen on clutter development scenes (README.md beside this file).

Every setting of :data:`SETTINGS` registers the same samples (``dataset=clutter``, protocol
``gt_model``, the scenes given, all in the ``dev`` part of ``configs/split/clutter.yaml``) through
:class:`catpose.methods.ppf.PPF` with ``top_k`` 5, exactly as ``bench run`` loads them. Each
sample's five refined candidates are scored (:func:`catpose.bench.scoring.metrics.sample_errors`)
and kept, so that the choice rule (``select``) and ``top_k`` 1 / 3 / 5 are compared on the same
registrations. Rows go to ``<work>/<setting>.jsonl`` (a killed run resumes); ``table`` writes one
row per setting, rule and ``top_k``: mean / median / @10 / @30 (degrees, failed = 180),
BOP's AR_MSSD and AR_MSPD (``bench score``'s code on a seeded 1,000-vertex subset of each model,
:data:`MODEL_POINTS`; VSD left out, it renders twice per target) and seconds.

    python experiments/ppf_settings/ppf_settings.py run --work DIR --scenes 0-19
    python experiments/ppf_settings/ppf_settings.py table --work DIR --out results/ppf/settings_dev.md
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

#: id -> PPF arguments; the first is the issue's setting (picked in advance from rendered views)
SETTINGS: dict[str, dict] = {
    "m05_s05_r5_a30": dict(model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=30),
    "m07_s05_r5_a30": dict(model_sampling=0.07, scene_sampling=0.05, scene_reference_step=5, num_angles=30),
    "m04_s04_r5_a30": dict(model_sampling=0.04, scene_sampling=0.04, scene_reference_step=5, num_angles=30),
    "m05_s03_r5_a30": dict(model_sampling=0.05, scene_sampling=0.03, scene_reference_step=5, num_angles=30),
    "m05_s05_r2_a30": dict(model_sampling=0.05, scene_sampling=0.05, scene_reference_step=2, num_angles=30),
    "m05_s05_r5_a20": dict(model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=20),
    "m05_s05_r5_a30_icp_all": dict(
        model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=30, icp_model="all"
    ),
    "m05_s05_r5_a30_no_icp": dict(
        model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=30, icp_iterations=0
    ),
    # round 2, after round 1 (README): select=chamfer gained most with more candidates, the denser
    # model and 20 angles were the best single changes; ten candidates, and the two together
    "m05_s05_r5_a20_k10": dict(
        model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=20, top_k=10
    ),
    "m04_s04_r5_a30_k10": dict(
        model_sampling=0.04, scene_sampling=0.04, scene_reference_step=5, num_angles=30, top_k=10
    ),
    "m04_s04_r5_a20_k10": dict(
        model_sampling=0.04, scene_sampling=0.04, scene_reference_step=5, num_angles=20, top_k=10
    ),
    # round 3, after round 2: ten candidates with the Chamfer choice were best at every setting;
    # twenty, and ten at 30 angles (does 20 angles still matter with ten candidates?)
    "m05_s05_r5_a20_k20": dict(
        model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=20, top_k=20
    ),
    "m05_s05_r5_a30_k10": dict(
        model_sampling=0.05, scene_sampling=0.05, scene_reference_step=5, num_angles=30, top_k=10
    ),
}
TOP_K = 5  # candidates refined and kept per sample, unless a setting names its own top_k
#: MSSD / MSPD on a seeded subset of this many vertices of each model (of ~7,900): the grid has 80
#: rows and the cans' 315 symmetry transforms make every vertex count; the suite tables use all
MODEL_POINTS = 1000
SELECTIONS = ("votes", "residual", "chamfer")


def scene_list(text: str) -> list[int]:
    """``0-19`` or ``0,3,5-7`` -> scene ids."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def dataset_overrides(root: str, scenes: list[int]) -> list[str]:
    return ["dataset=clutter", f"dataset.root={root}", f"dataset.scenes=[{','.join(map(str, scenes))}]"]


def run_setting(name: str, work: Path, root: str, scenes: list[int]) -> None:
    """Register every sample of the scenes with setting ``name``; rows appended to ``<work>/<name>.jsonl``."""
    from catpose.bench.real.split import load_split
    from catpose.bench.run.config import compose_and_build
    from catpose.bench.run.sample_run import seed_everything
    from catpose.bench.scoring.metrics import sample_errors
    from catpose.geometry import stable_seed
    from catpose.methods.ppf import PPF

    dev = set(load_split("clutter").scene_ids("dev"))
    if not set(scenes) <= dev:
        raise SystemExit(f"scenes {sorted(set(scenes) - dev)} are not development scenes (configs/split/clutter.yaml)")
    _, ((_, dataset), (_, protocol)) = compose_and_build(
        [*dataset_overrides(root, scenes), "protocol=gt_model"], ("dataset", "protocol")
    )
    method = PPF(**{"top_k": TOP_K, **SETTINGS[name]}, select="votes")
    out = work / f"{name}.jsonl"
    done = {json.loads(x)["sample_id"] for x in out.read_text().splitlines()} if out.is_file() else set()
    work.mkdir(parents=True, exist_ok=True)
    for sid in protocol.sample_ids(dataset):
        if sid in done:
            continue
        sample = protocol.load(dataset, sid)
        gt = sample.gt
        seed_everything(stable_seed(0, sid))
        t0 = time.perf_counter()
        row = {"sample_id": sid, "category": sample.problem.category, "info": dict(sample.info)}
        try:
            r = method.register(sample.problem)
        except Exception as e:  # noqa: BLE001 - a failed sample counts as 180 degrees, as in bench run
            row.update(status="failed", error=" ".join(str(e).split())[:300], runtime_s=time.perf_counter() - t0)
        else:
            errors = [sample_errors(T, gt.T_template_camera, gt.symmetry_axis, gt.symmetries) for T in r.candidates_T]
            keep = ("model_s", "match_s", "icp_s", "votes", "icp_residual", "candidate_chamfer", "scene_points")
            row.update(
                status="ok",
                runtime_s=time.perf_counter() - t0,
                candidates_T=[np.asarray(T, float).reshape(-1).tolist() for T in r.candidates_T],
                candidate_err_deg=[e["err_deg"] for e in errors],
                **{k: r.extras[k] for k in keep},
            )
        with out.open("a") as f:
            f.write(json.dumps(row) + "\n")


def chosen(row: dict, select: str, top_k: int) -> int | None:
    """The index of the candidate ``select`` keeps among the first ``top_k`` (None: failed)."""
    if row["status"] != "ok":
        return None
    k = min(top_k, len(row["votes"]))
    if select == "votes":
        return 0
    key = "icp_residual" if select == "residual" else "candidate_chamfer"
    return int(np.argmin(row[key][:k]))


def table(work: Path, root: str, scenes: list[int]) -> str:
    """Markdown: one row per setting, selection rule and top_k (rules coincide at top_k 1)."""
    import pandas as pd
    from omegaconf import OmegaConf

    from catpose.bench.run.bop_ar import evaluation_models, predictions_from_units, target_key
    from catpose.bench.run.build import build_from_config
    from catpose.bench.run.config import compose
    from catpose.bench.scoring.bop_eval import compute_errors, metric_value

    cfg = OmegaConf.to_container(compose(dataset_overrides(root, scenes)).dataset, resolve=True)
    _, dataset = build_from_config(evaluation_models(cfg), "dataset")
    lines = [
        f"PPF settings on clutter development scenes {scenes[0]}-{scenes[-1]} (dataset=clutter, gt_model, own "
        "model); failed = 180 deg and a BOP miss; AR_MSSD / AR_MSPD on 1,000 vertices of each model; s: "
        "median seconds per sample with all the setting's candidates (match + ICP of each; wall time on a "
        "shared machine, so a rough guide); training: the most seconds one object's model took (models are "
        "shared by settings with the same model_sampling and num_angles). Without ICP the residual is 0: "
        "residual then keeps the most votes",
        "",
        "| setting | select | top_k | n | failed | mean | med | @10 | @30 | AR_MSSD | AR_MSPD | s | training s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    runs = {
        name: [json.loads(x) for x in (work / f"{name}.jsonl").read_text().splitlines() if x.strip()]
        for name in SETTINGS
        if (work / f"{name}.jsonl").is_file()
    }

    def model_of(name: str) -> tuple:
        return SETTINGS[name]["model_sampling"], SETTINGS[name]["num_angles"]

    trained: dict[tuple, float] = {}  # a model is trained by the first setting that needs it
    for name, rows in runs.items():
        seconds = [r["model_s"] for r in rows if r["status"] == "ok"]
        trained[model_of(name)] = max(trained.get(model_of(name), 0.0), *seconds)
    for name, rows in runs.items():
        ok = [r for r in rows if r["status"] == "ok"]
        seconds = float(np.median([r["runtime_s"] - r["model_s"] for r in ok])) if ok else float("nan")
        training = trained[model_of(name)]
        k_max = SETTINGS[name].get("top_k", TOP_K)
        ks = [k for k in (3, 5, 10, 20) if k <= k_max]
        for top_k, select in [(1, "votes"), *[(k, s) for k in ks for s in SELECTIONS]]:
            picks = [chosen(r, select, top_k) for r in rows]
            err = np.array([180.0 if p is None else r["candidate_err_deg"][p] for r, p in zip(rows, picks)])
            units = [
                dict(status="ok", T_est=r["candidates_T"][p], score=None, info=r["info"], sample_id=r["sample_id"])
                for r, p in zip(rows, picks)
                if p is not None
            ]
            wanted = {target_key(r["info"]) for r in rows}
            errs = pd.DataFrame(
                [
                    e
                    for e in compute_errors(predictions_from_units(units), dataset, vsd=False, max_points=MODEL_POINTS)
                    if target_key(e) in wanted
                ]
            )
            lines.append(
                f"| {name} | {select if top_k > 1 else '-'} | {top_k} | {len(rows)} | {sum(p is None for p in picks)} | "
                f"{err.mean():.2f} | {np.median(err):.2f} | {(err < 10).mean():.3f} | {(err < 30).mean():.3f} | "
                f"{metric_value(errs, 'ar_mssd'):.3f} | {metric_value(errs, 'ar_mspd'):.3f} | "
                f"{seconds:.2f} | {training:.1f} |"
            )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["run", "table"])
    ap.add_argument("--work", type=Path, required=True, help="folder of the per-setting rows (outside the repository)")
    ap.add_argument("--root", default="../shared/data/bop/ycbv", help="the BOP folder with the YCB-V models")
    ap.add_argument("--scenes", default="0-19", help="development scenes, e.g. 0-19")
    ap.add_argument("--settings", default=",".join(SETTINGS), help="comma-separated ids of SETTINGS")
    ap.add_argument("--out", type=Path, default=None, help="table: write the Markdown here")
    args = ap.parse_args()
    scenes = scene_list(args.scenes)
    if args.command == "run":
        for name in args.settings.split(","):
            print(f"ppf_settings: {name} ...", flush=True)
            run_setting(name, args.work, args.root, scenes)
        return
    text = table(args.work, args.root, scenes)
    print(text)
    if args.out:
        from catpose import atomic

        atomic.write_text(args.out, text)


if __name__ == "__main__":
    main()
