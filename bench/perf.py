"""``bench perf``: seconds per registration, and per stage for ``ours``, on the same problems.

Problems: the synthetic dataset (``catpose.datasets.synthetic``, ``gt_model`` protocol: each view
against its own instance's model) when importable, otherwise rendered views of a small built-in
box chair. Methods are built from ``configs/method/<name>.yaml`` (the configured defaults; change
``ours`` options with ``--set key=value``). Each template is registered once untimed first, so the
one-off dictionary and template-descriptor build (cached afterwards) is reported apart as
``warmup_s`` and excluded from the per-registration numbers.

Usage::

    bench perf                       # 12 problems, ours and icp
    bench perf --n 24 --methods ours --set descriptor=pfh --threads 1
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

STAGES = ("dictionary", "descriptors", "affinity", "initial_pose", "optimization", "selection", "refinement")


def _problems(n: int, seed: int, categories: list[str] | None):
    """Up to ``n`` RegistrationProblems (and a label saying where they come from)."""
    try:
        from catpose.bench.protocols import make_sample
        from catpose.datasets.synthetic import SyntheticDataset
    except ImportError:
        SyntheticDataset = None
    if SyntheticDataset is not None:
        cats = categories or ["airplane", "chair", "car", "mug"]
        per = max(1, -(-n // len(cats)))
        ds = SyntheticDataset(seed=seed, categories=cats, instances_per_category=max(1, -(-per // 2)),
                              views_per_instance=2)
        out = []
        for obs_id in ds.observation_ids():
            obs = ds.observation(obs_id)
            out.append(make_sample(obs, ds.instance_model(obs.category, obs.instance_id), obs_id, obs_id).problem)
        # interleave categories so --n takes every category
        by_cat: dict[str, list] = {}
        for p in out:
            by_cat.setdefault(p.category, []).append(p)
        mixed = [p for group in zip(*by_cat.values()) for p in group]
        return mixed[:n], f"synthetic (seed {seed}, gt_model)"
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from _ours_fixtures import chair_template, partial_problem

    t = chair_template()
    return [partial_problem(t, s)[0] for s in range(n)], "built-in box chair"


def _method(name: str, seed: int, overrides: dict):
    """Build a method from its config exactly as the runner does (Hydra defaults lists included)."""
    from hydra import compose, initialize_config_module
    from omegaconf import OmegaConf

    from catpose.bench.build import build_from_config

    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose(config_name="run", overrides=[f"method={name}", f"seed={seed}"])
    return build_from_config(OmegaConf.merge(cfg.method, overrides), "method")[1]


def _stats(xs: list[float]) -> tuple[float, float]:
    return (statistics.median(xs), statistics.fmean(xs)) if xs else (float("nan"), float("nan"))


def main(argv: list[str] | None = None) -> int:
    import yaml

    ap = argparse.ArgumentParser(prog="bench perf", description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=12, help="number of problems (default 12)")
    ap.add_argument("--methods", default="ours,icp", help="comma-separated method config names")
    ap.add_argument("--categories", default=None, help="comma-separated synthetic categories")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1, help="torch intra-op threads (default 1)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override an ours option")
    args = ap.parse_args(argv)

    import numpy as np
    import torch
    from tabulate import tabulate

    torch.set_num_threads(max(1, args.threads))
    overrides = {}
    for kv in args.set:
        key, _, value = kv.partition("=")
        overrides[key] = yaml.safe_load(value)
    problems, source = _problems(args.n, args.seed, args.categories.split(",") if args.categories else None)
    rows, stage_rows = [], []
    for name in [m.strip() for m in args.methods.split(",") if m.strip()]:
        try:
            method = _method(name, args.seed, overrides if name == "ours" else {})
        except Exception as e:  # a method whose module or config is missing or broken: skip it, say why
            print(f"skipping {name}: {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}")
            continue
        warm = 0.0
        seen = set()
        for p in problems:  # one untimed call per template builds its caches
            if p.template.template_id not in seen:
                seen.add(p.template.template_id)
                np.random.seed(0)
                t0 = time.perf_counter()
                method.register(p)
                warm += time.perf_counter() - t0
        times, stages = [], {s: [] for s in STAGES}
        for p in problems:
            np.random.seed(0)
            t0 = time.perf_counter()
            r = method.register(p)
            times.append(time.perf_counter() - t0)
            for s, v in dict(r.extras).get("timings", {}).items():
                if s in stages:
                    stages[s].append(float(v))
        med, mean = _stats(times)
        rows.append([name, len(times), f"{med:.3f}", f"{mean:.3f}", f"{warm:.2f}"])
        for s in STAGES:
            if stages[s]:
                sm, sa = _stats(stages[s])
                stage_rows.append([name, s, f"{sm:.4f}", f"{sa:.4f}"])
    print(f"problems: {len(problems)} from {source}; torch threads {torch.get_num_threads()}")
    print(tabulate(rows, headers=["method", "n", "median_s", "mean_s", "warmup_s (caches, excluded)"], tablefmt="github"))
    if stage_rows:
        print()
        print(tabulate(stage_rows, headers=["method", "stage", "median_s", "mean_s"], tablefmt="github"))
    return 0
