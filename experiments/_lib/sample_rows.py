"""The per-sample loop of ours' studies (``rest_recall``, ``depth_check_masks``, ``outside_mask``,
``key_audit``, ``seed_free``): ours and the problems built and seeded as ``bench run`` builds and
seeds them, so their answers are the run's; one JSON line per sample, finished samples skipped on a
rerun; every variant of a study on each problem back to back (:func:`variant_rows`); and the tables'
reading of those lines."""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def build(seed: int, overrides: list[str]) -> tuple[Any, Any, Any, Any]:
    """(cfg, method, dataset, protocol) of ``bench run method=ours seed=SEED threads=1 OVERRIDES``,
    with the kernels' threads set as the run sets them."""
    from catpose import kernel_threads
    from catpose.bench.run.config import compose_and_build

    cfg, [(_, method), (_, dataset), (_, protocol)] = compose_and_build(
        ["method=ours", f"seed={seed}", "threads=1", *overrides], ["method", "dataset", "protocol"]
    )
    kernel_threads.set_threads(cfg.get("threads"))
    return cfg, method, dataset, protocol


def read_rows(path: Path) -> list[dict]:
    """The JSON lines of ``path`` (none when it does not exist)."""
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def done_ids(path: Path) -> set[str]:
    """The samples ``path`` already holds."""
    return {r["sample_id"] for r in read_rows(path)}


def register_seeded(method: Any, problem: Any, seed: int, sample_id: str) -> tuple[Any, float]:
    """``method.register(problem)`` seeded per sample as ``bench run`` seeds it, and its seconds."""
    from catpose.geometry import seed_everything, stable_seed

    seed_everything(stable_seed(seed, sample_id))
    t0 = time.perf_counter()
    result = method.register(problem)
    return result, time.perf_counter() - t0


def answer_errors(result: Any, gt: Any) -> tuple[np.ndarray, float, dict, float]:
    """(the answer's pose, its error, the error of each stage's best held pose, found@10's error:
    the least of them), in degrees."""
    from catpose.bench.scoring.metrics import sample_errors, stage_errors

    T = np.asarray(result.T_template_camera, float)
    err = float(sample_errors(T, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)["err_deg"])
    stages = stage_errors(
        result.extras.get("hypothesis_stages", {}), gt.T_template_camera, gt.symmetry_axis, gt.symmetries
    )
    return T, err, stages, float(np.nanmin([err, *stages.values()]))


def slug(variant: str) -> str:
    """The file name of a variant's lines (``grid_icp yaw`` -> ``grid_icp-yaw``)."""
    return "-".join("".join(c if c.isalnum() or c in "._" else " " for c in variant).split())


def variant_rows(
    out_dir: Path,
    seed: int,
    names: list[str],
    dataset: Any,
    protocol: Any,
    method_for: Callable[[str], Any],
    warm_each: bool = False,
    extra: Callable[[], dict] | None = None,
) -> None:
    """Every sample of ``protocol`` on ``dataset`` registered by each variant of ``names`` in turn
    (``method_for(v)``: the method of variant ``v``, after installing whatever the variant patches),
    one JSON line per sample into ``out_dir/<slug(v)>.jsonl``: the answer's error, found@10's best
    error over ours' held poses, the seconds (the variants back to back on the same problem, so
    their seconds pair up; who goes first rotates), the answer relative to the truth (``T_rel`` =
    T_est T_gt^-1, with the truth's symmetries: the seeds' agreement) and ``extra()``'s fields.
    A template's caches are built before any timed run (by the first variant, or by each when
    ``warm_each``); finished samples already in a variant's file are skipped."""
    from catpose.geometry import compose_T, invert_T

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {v: out_dir / f"{slug(v)}.jsonl" for v in names}
    done = {v: done_ids(p) for v, p in paths.items()}
    t_all = time.time()
    files = {v: p.open("a") for v, p in paths.items()}
    seen = set()
    for i, sid in enumerate(protocol.sample_ids(dataset)):
        todo = [v for v in names if sid not in done[v]]
        if not todo:
            continue
        s = protocol.load(dataset, sid)
        p, gt = s.problem, s.gt
        if p.template.template_id not in seen:
            seen.add(p.template.template_id)
            for v in todo if warm_each else todo[:1]:
                method_for(v).register(p)
        k = i % len(todo)
        for v in todo[k:] + todo[:k]:
            r, seconds = register_seeded(method_for(v), p, seed, sid)
            T, err, _, found = answer_errors(r, gt)
            axis = gt.symmetry_axis
            row = {
                "sample_id": sid,
                "seed": seed,
                "category": p.category,
                "obj_id": int((s.info or {}).get("obj_id", -1)),
                "err_deg": err,
                "found_err_deg": found,
                "seconds": seconds,
                "T_rel": compose_T(T, invert_T(np.asarray(gt.T_template_camera, float))).tolist(),
                "symmetry_axis": None if axis is None else [float(x) for x in np.asarray(axis).ravel()],
                "symmetries": [np.asarray(x, float).tolist() for x in (gt.symmetries or ())],
                **(extra() if extra else {}),
            }
            files[v].write(json.dumps(row) + "\n")
            files[v].flush()
    for f in files.values():
        f.close()
    print(f"{out_dir} seed {seed}: done in {time.time() - t_all:.0f} s")


#: the seeds every study judges over
SEEDS = (0, 1, 2)
#: configs/split/clutter_objects.yaml: the clutter dev scenes' object halves
HALVES = {"dev_A": (1, 6, 9, 12), "dev_B": (4, 5, 13, 14)}
#: BOP YCB-V object ids -> names: the clutter set's eight objects (the shared frames hold 1, 5 and 9)
OBJECTS = {
    1: "master chef can",
    4: "tomato soup can",
    5: "mustard bottle",
    6: "tuna fish can",
    9: "potted meat can",
    12: "bleach cleanser",
    13: "bowl",
    14: "mug",
}


def at10(rows: list[dict], key: str = "err_deg") -> float:
    return float(np.mean([r[key] <= 10.0 for r in rows])) if rows else float("nan")


def load(runs: Path, source: str, variant: str, seeds: tuple[int, ...] = SEEDS) -> dict[int, list[dict]]:
    """Seed -> the variant's rows on ``source`` under ``seeds`` (seeds without rows left out)."""
    out = {s: read_rows(runs / f"{source}-seed{s}" / f"{variant}.jsonl") for s in seeds}
    return {s: rows for s, rows in out.items() if rows}


def write_table(out: Path, lines: list[str]) -> int:
    """A study's table: ``lines`` into ``out`` (its folder made), its path printed; 0 (the exit code)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(out)
    return 0


def delta(mine: dict[int, list[dict]], ref: dict[int, list[dict]], objs: tuple | None = None) -> float:
    """The variant's @10 minus the default's on the same views of each seed (only the objects
    ``objs`` when given), mean over the seeds both have; NaN without any."""
    diffs = []
    for s, rows in mine.items():
        by_id = {r["sample_id"]: r for r in ref.get(s, [])}
        paired = [(r, by_id[r["sample_id"]]) for r in rows if r["sample_id"] in by_id]
        if objs is not None:
            paired = [(a, b) for a, b in paired if a["obj_id"] in objs]
        if paired:
            diffs.append(at10([a for a, _ in paired]) - at10([b for _, b in paired]))
    return float(np.mean(diffs)) if diffs else float("nan")


def agreement(seeds: dict[int, list[dict]]) -> float:
    """``bench suite``'s agree (:func:`catpose.bench.real.suite_table.seed_agreement`): the fraction
    of the views every seed answered whose answers (relative to the truth) lie pairwise within 10
    deg; NaN unless all three seeds ran."""
    from catpose.bench.real.suite_table import seed_agreement

    if len(seeds) < len(SEEDS):
        return float("nan")
    per_seed = [
        {
            r["sample_id"]: (
                np.asarray(r["T_rel"]),
                r["symmetry_axis"] and np.asarray(r["symmetry_axis"]),
                r["symmetries"],
            )
            for r in rows
        }
        for rows in seeds.values()
    ]
    return seed_agreement(per_seed)


def seconds(mine: dict[int, list[dict]]) -> float:
    return statistics.median(r["seconds"] for rows in mine.values() for r in rows)


def f3(x: float) -> str:
    return "n/a" if x != x else f"{x:+.3f}"


def spread(values: list[float]) -> str:
    """``mean`` or ``mean [min-max]`` of per-seed figures; ``n/a`` without any."""
    if not values:
        return "n/a"
    a = np.asarray(values)
    if a.max() - a.min() < 5e-4:
        return f"{a.mean():.3f}"
    return f"{a.mean():.3f} [{a.min():.3f}-{a.max():.3f}]"
