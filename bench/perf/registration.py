"""``bench perf``: seconds per registration of several methods on the same problems, interleaved.

Problems are the first ``--n`` samples of a configured dataset, built as ``bench run`` builds
them; every method registers each new template once untimed, then ``--repeat`` rounds call
every method back to back, the order rotating per round, so load changes hit all methods alike.

    bench perf                                    # 12 synthetic problems, ours, icp, fgr, 3 rounds
    bench perf --n 24 --methods ours,adam=ours,fgr --repeat 5 --set adam:optimiser.solver=adam
    bench perf --dataset redwood --root ../shared/data/redwood --n 12
    bench perf --methods ours,fgr --set optimiser.device=cuda"""

from __future__ import annotations

import argparse
import csv
import itertools
import logging
import os
import resource
import statistics
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from catpose import extras, kernel_threads
from catpose.errors import ConfigError

log = logging.getLogger(__name__)

STAGES = (
    "dictionary",
    "descriptors",
    "affinity",
    "initial_pose",
    "optimization",
    "selection",
    "refinement",
    "hypotheses",
    "rest_grid",
    "verification",
)
REFERENCE = "fgr"


def load_problems(
    dataset: str, protocol: str, n: int, seed: int, root: str | None = None, overrides: Sequence[str] = ()
) -> tuple[list, str]:
    """The first ``n`` problems of ``dataset`` under ``protocol`` (round-robin over categories),
    built exactly as ``bench run`` builds them, and a label saying where they come from."""
    from catpose.bench.run.config import compose_and_build

    ov = [f"dataset={dataset}", f"protocol={protocol}", f"seed={seed}", *overrides]
    if root:
        ov.append(f"dataset.root={root}")
    _, ((name, ds), (_, proto)) = compose_and_build(
        ov, ("dataset", "protocol"), hint="check --dataset/--protocol/--dataset-set"
    )
    by_cat: dict[str, list[str]] = {}
    for sid in proto.sample_ids(ds):
        by_cat.setdefault(str(ds.category_of(sid.split("|")[0])), []).append(sid)
    rounds = itertools.zip_longest(*by_cat.values())  # the first of each category, then the second, ...
    ids = [sid for sid in itertools.chain.from_iterable(rounds) if sid is not None][:n]
    if not ids:
        raise ConfigError(f"dataset {name} ({protocol}) has no samples; check --root / --dataset-set")
    return [proto.load(ds, sid).problem for sid in ids], f"{name} ({protocol}, seed {seed})"


def build_method(name: str, seed: int, overrides: Sequence[str] = ()) -> Any:
    """Build a method from its config exactly as the runner does (``overrides`` are ``key=value``
    relative to the method node)."""
    from catpose.bench.run.config import compose_and_build

    _, ((_, method),) = compose_and_build(
        [f"method={name}", f"seed={seed}", *[f"method.{kv}" for kv in overrides]],
        ("method",),
        hint="check --methods/--set",
    )
    return method


def parse_methods(spec: str) -> list[tuple[str, str]]:
    """``ours,adam=ours,fgr`` -> [(label, config name)]: a label lets one config run twice with
    different ``--set LABEL:KEY=VALUE`` options in the same interleaved run."""
    out = []
    for item in (s.strip() for s in spec.split(",")):
        if item:
            label, _, name = item.partition("=")
            out.append((label.strip(), (name or label).strip()))
    labels = [lab for lab, _ in out]
    if len(set(labels)) != len(labels):
        raise ConfigError(f"--methods {spec!r} repeats a label; name copies like adam=ours")
    return out


def method_overrides(label: str, name: str, sets: Sequence[str]) -> list[str]:
    """The ``--set`` options for one method: ``LABEL:KEY=VALUE`` for that label, plain
    ``KEY=VALUE`` for every ``ours``."""
    out = []
    for kv in sets:
        target, sep, rest = kv.partition(":")
        if sep and "=" not in target:
            if target == label:
                out.append(rest)
        elif name == "ours":
            out.append(kv)
    return out


def _seeded(seed: int, sample_id: str) -> None:
    from catpose.bench.run.sample_run import seed_everything
    from catpose.geometry import stable_seed

    seed_everything(stable_seed(seed, sample_id))


def _register(method: Any, problem: Any) -> Any:
    """``method.register(problem)``, or None when the method gives no pose for it."""
    from catpose.errors import InvalidInputError

    try:
        return method.register(problem)
    except InvalidInputError:
        return None


def measure(methods: dict[str, Any], problems: list, repeat: int, seed: int) -> dict[str, dict]:
    """Time every method on every problem, ``repeat`` times, interleaved call by call (see the
    module docstring). A registration that gives no pose (:class:`InvalidInputError`) is timed like
    any other and counted in ``failed``.

    Returns per method: ``times`` (s per registration, in call order), ``stages`` (stage -> list
    of s, ours only), ``warmup_s`` and ``failed``."""
    out = {name: {"times": [], "stages": {s: [] for s in STAGES}, "warmup_s": 0.0, "failed": 0} for name in methods}
    names = list(methods)
    seen: set = set()
    for p in problems:
        if p.template.template_id not in seen:  # one untimed call per new template builds its caches
            for name, method in methods.items():
                _seeded(seed, p.sample_id)
                t0 = time.perf_counter()
                _register(method, p)
                out[name]["warmup_s"] += time.perf_counter() - t0
            seen.add(p.template.template_id)
        for r in range(repeat):
            for name in names[r % len(names) :] + names[: r % len(names)]:
                rec = out[name]
                _seeded(seed, p.sample_id)
                t0 = time.perf_counter()
                res = _register(methods[name], p)
                rec["times"].append(time.perf_counter() - t0)
                if res is None:
                    rec["failed"] += 1
                    continue
                for s, v in dict(res.extras).get("timings", {}).items():
                    if s in rec["stages"]:
                        rec["stages"][s].append(float(v))
    return out


def summarize(measured: dict[str, dict]) -> list[dict]:
    """One row per method: n, median/mean/p90 seconds, ratio to FGR's median, warm-up seconds."""
    import numpy as np

    ref = measured.get(REFERENCE)
    ref_median = statistics.median(ref["times"]) if ref and ref["times"] else None
    rows = []
    for name, rec in measured.items():
        xs = rec["times"]
        med = statistics.median(xs)
        rows.append(
            {
                "method": name,
                "n": len(xs),
                "median_s": med,
                "mean_s": statistics.fmean(xs),
                "p90_s": float(np.percentile(xs, 90)),
                f"ratio_to_{REFERENCE}": med / ref_median if ref_median else float("nan"),
                "warmup_s": rec["warmup_s"],
                "failed": rec.get("failed", 0),
            }
        )
    return rows


def _write_csv(path: Path, rows: list[dict]) -> None:
    from catpose import atomic

    with atomic.atomic_write(path, newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def main(argv: list[str] | None = None) -> int:
    import yaml

    ap = argparse.ArgumentParser(prog="bench perf", description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=12, help="number of problems (default 12)")
    ap.add_argument("--repeat", type=int, default=3, help="interleaved timing rounds (default 3)")
    ap.add_argument(
        "--methods",
        default="ours,icp,fgr",
        help="comma-separated method config names; LABEL=NAME runs a config under another label",
    )
    ap.add_argument("--dataset", default="synthetic", help="dataset config name (default synthetic)")
    ap.add_argument("--root", default=None, help="dataset root (sets dataset.root)")
    ap.add_argument("--protocol", default="gt_model", help="protocol config name (default gt_model)")
    ap.add_argument(
        "--dataset-set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a dataset option (e.g. instances_per_category=1, categories=[mug,chair])",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--threads",
        default=kernel_threads.AUTO,
        help="the runs' threads key: ours' compiled kernels split over this many threads, and torch's intra-op "
        f"threads (default {kernel_threads.AUTO}, as in runs: the CPUs this process may use; the CSV records the count)",
    )
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="[LABEL:]KEY=VALUE",
        help="override an option of ours (KEY=VALUE) or of the method LABEL (LABEL:KEY=VALUE)",
    )
    from catpose.bench.run.overwrite import Output, add_output_options

    add_output_options(ap, "CSV path (default outputs/perf/<parameters>.csv, replaced)", required=False)
    args = ap.parse_args(argv)
    if args.n < 1 or args.repeat < 1:
        raise ConfigError("--n and --repeat must be at least 1")
    try:
        threads = kernel_threads.resolve(int(args.threads) if args.threads.strip().isdigit() else args.threads)
    except ValueError:
        raise ConfigError(f"--threads {args.threads!r}: give {kernel_threads.AUTO} or an integer at least 1") from None
    for kv in args.set + args.dataset_set:
        if "=" not in kv:
            raise ConfigError(f"--set/--dataset-set {kv!r} is not KEY=VALUE")
        yaml.safe_load(kv.partition("=")[2])  # a malformed value fails here, before any work
    # before any work: the output rule (docs/file-safety.md); the default is perf's own
    out = Path(args.out or f"outputs/perf/{args.dataset}-{args.protocol}-n{args.n}-r{args.repeat}.csv")
    outs = [
        Output(p, "file", (), args.force or not args.out, example="perf.csv")
        for p in (out, *(out.with_name(f"{out.stem}_{k}.csv") for k in ("times", "stages")))
    ]
    from tabulate import tabulate

    kernel_threads.set_threads(threads)
    load_before = os.getloadavg()
    ds_over = [f"dataset.{kv}" for kv in args.dataset_set]
    problems, source = load_problems(args.dataset, args.protocol, args.n, args.seed, args.root, ds_over)
    methods: dict[str, Any] = {}
    for label, name in parse_methods(args.methods):
        over = method_overrides(label, name, args.set)
        try:
            methods[label] = build_method(name, args.seed, over)
        except Exception as e:  # a method whose module or config is missing or broken: skip it, say why
            log.warning("skipping %s: %s: %s", label, type(e).__name__, str(e).splitlines()[0] if str(e) else "")
    if not methods:
        raise ConfigError(f"none of --methods {args.methods} could be built")
    measured = measure(methods, problems, args.repeat, args.seed)
    load_after = os.getloadavg()
    rows = summarize(measured)
    peak_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB
    stage_rows = [
        {"method": name, "stage": s, "median_s": statistics.median(v), "mean_s": statistics.fmean(v)}
        for name, rec in measured.items()
        for s, v in rec["stages"].items()
        if v
    ]

    print(
        f"problems: {len(problems)} from {source}; {args.repeat} interleaved rounds; threads "
        f"{kernel_threads.threads()} (torch: {extras.torch_threads() or 'n/a, not installed'}); "
        f"load average {load_before[0]:.1f} before, "
        f"{load_after[0]:.1f} after on {os.cpu_count()} CPUs; peak RSS {peak_rss:.0f} MiB (the process, all methods)"
    )
    print(tabulate(rows, headers="keys", tablefmt="github", floatfmt=".3f"))
    if stage_rows:
        print()
        print(tabulate(stage_rows, headers="keys", tablefmt="github", floatfmt=".4f"))
    meta = {
        "source": source,
        "repeat": args.repeat,
        "threads": kernel_threads.threads(),
        "load_before": round(load_before[0], 2),
        "load_after": round(load_after[0], 2),
        "cpus": os.cpu_count(),
        "peak_rss_mb": round(peak_rss, 1),
    }
    times = [
        {"method": name, "call": i, "seconds": x} for name, rec in measured.items() for i, x in enumerate(rec["times"])
    ]
    with outs[0].writing(), outs[1].writing(), outs[2].writing():
        for o, table in zip(outs, ([dict(r, **meta) for r in rows], times, stage_rows)):
            if table:
                _write_csv(o.path, table)
    print(f"\nwrote {out} (and {out.stem}_times.csv{', ' + out.stem + '_stages.csv' if stage_rows else ''})")
    return 0
