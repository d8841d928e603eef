"""``bench regress``: CI regression of ours and the baselines on small fixed subsets.

Each suite of ``configs/regress/default.yaml`` (a dataset + protocol + seed + overrides and a
list of methods) is run through the runner into a temporary folder, summarised per category,
and compared with the committed reference (``results/reference/<suite>.json``) within the
stated tolerances (absolute, per statistic). A regression prints a per-metric diff and exits 1;
``--update`` rewrites the reference from the current code. Methods whose config or module is
missing (or whose optional dependency is absent) are skipped with a note, never failed.

    bench regress                      # every suite (shared-data suites only when present)
    bench regress --suite synthetic --methods icp,ours
    bench regress --update             # after an intended change: commit the new reference
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from catpose.errors import CatposeError, ConfigError

REPO = Path(__file__).resolve().parents[1]
DEFAULT_CONFIG = REPO / "configs" / "regress" / "default.yaml"
STATISTICS = ("n", "failed", "mean_err_deg", "median_err_deg", "acc10", "acc30", "mean_trans_err")


@dataclass(frozen=True)
class Diff:
    """One compared statistic: ``ok`` when ``|current - reference| <= tolerance`` (NaN == NaN)."""

    suite: str
    method: str
    category: str
    statistic: str
    reference: float | None
    current: float | None
    tolerance: float

    @property
    def ok(self) -> bool:
        r, c = self.reference, self.current
        if r is None or c is None:
            return False
        if math.isnan(r) or math.isnan(c):
            return math.isnan(r) and math.isnan(c)
        return abs(c - r) <= self.tolerance + 1e-9


def shared_data_dir() -> Path:
    """``$CATPOSE_SHARED_DATA`` or ``../shared/data`` beside the checkout."""
    env = os.environ.get("CATPOSE_SHARED_DATA")
    return Path(env) if env else REPO.parent / "shared" / "data"


def load_config(path: str | Path = DEFAULT_CONFIG) -> dict:
    """The regress config as a plain dict (raises :class:`ConfigError` when malformed)."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"regress config {path} does not exist; pass --config FILE")
    cfg = yaml.safe_load(path.read_text()) or {}
    if not isinstance(cfg.get("suites"), dict) or not cfg["suites"]:
        raise ConfigError(f"{path} has no 'suites' mapping; see configs/regress/default.yaml")
    for name, suite in cfg["suites"].items():
        for key in ("dataset", "protocol", "methods", "reference"):
            if key not in suite:
                raise ConfigError(f"{path}: suite {name!r} lacks {key!r}")
    return cfg


def method_available(name: str) -> str | None:
    """None when ``configs/method/<name>.yaml`` and its module exist, else why not."""
    import importlib.util

    import yaml

    cfg_path = REPO / "configs" / "method" / f"{name}.yaml"
    if not cfg_path.is_file():
        return f"no configs/method/{name}.yaml"
    target = str((yaml.safe_load(cfg_path.read_text()) or {}).get("_target_", ""))
    module = target.rpartition(".")[0]
    try:
        if not module or importlib.util.find_spec(module) is None:
            return f"module {module or '?'} does not exist yet"
    except ModuleNotFoundError:
        return f"module {module} does not exist yet"
    return None


def run_suite(name: str, suite: dict, methods: Sequence[str] | None, out_root: Path,
              log=print) -> tuple[dict[str, dict[str, dict[str, float]]], list[str]]:
    """Run a suite's methods through the runner.

    Returns ({method: {category: {statistic: value}}}, notes about skipped methods).
    """
    import pandas as pd
    from hydra import compose, initialize_config_module

    from catpose.bench.runner import run

    results: dict[str, dict[str, dict[str, float]]] = {}
    notes: list[str] = []
    shared = str(shared_data_dir())
    base = [f"dataset={suite['dataset']}", f"protocol={suite['protocol']}", f"seed={int(suite.get('seed', 0))}",
            f"output_root={out_root / name}", "progress=false", "print_summary=false"]
    base += [str(o).replace("{shared_data}", shared) for o in suite.get("overrides") or []]
    for method in methods or suite["methods"]:
        why = method_available(method)
        if why:
            notes.append(f"{name}/{method}: skipped ({why})")
            continue
        overrides = base + [f"method={method}"] + list((suite.get("method_overrides") or {}).get(method, []))
        t0 = time.perf_counter()
        try:
            with initialize_config_module("catpose.configs", version_base=None):
                cfg = compose("run", overrides=overrides)
            run_dir = run(cfg, overrides)
        except (CatposeError, ImportError) as e:
            notes.append(f"{name}/{method}: skipped ({' '.join(str(e).split())})")
            continue
        summary = pd.read_csv(run_dir / "summary.csv")
        results[method] = {str(r["category"]): {s: _num(r.get(s)) for s in STATISTICS} for r in summary.to_dict("records")}
        log(f"  {name}/{method}: {time.perf_counter() - t0:.1f} s, mean error (all) "
            f"{results[method].get('all', {}).get('mean_err_deg', float('nan')):.3f} deg")
    return results, notes


def _num(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def compare(suite: str, reference: dict, current: dict, tolerances: dict[str, float],
            methods: Sequence[str]) -> tuple[list[Diff], list[str]]:
    """Diff every statistic of every (method, category) of ``current`` against ``reference``.

    Only ``methods`` (those that ran) are compared; a method or category present on one side
    only is reported as a failing diff (a category lost or gained is a change), a method without
    any reference as a note (run ``--update`` to add it).
    """
    diffs: list[Diff] = []
    notes: list[str] = []
    for method in methods:
        ref_m, cur_m = reference.get(method), current.get(method, {})
        if ref_m is None:
            notes.append(f"{suite}/{method}: no reference yet (run `bench regress --update` and commit it)")
            continue
        for category in sorted(set(ref_m) | set(cur_m)):
            for stat in STATISTICS:
                r = ref_m.get(category, {}).get(stat)
                c = cur_m.get(category, {}).get(stat)
                diffs.append(Diff(suite, method, category, stat, None if r is None else _num(r),
                                  None if c is None else _num(c), float(tolerances.get(stat, 0.0))))
    return diffs, notes


def format_failures(diffs: Sequence[Diff]) -> str:
    """The failing diffs as a readable table."""
    bad = [d for d in diffs if not d.ok]
    if not bad:
        return ""
    head = f"{'suite/method':<24} {'category':<10} {'statistic':<15} {'reference':>10} {'current':>10} {'diff':>9} {'tol':>6}"
    lines = [head, "-" * len(head)]
    for d in bad:
        fmt = lambda v: "missing" if v is None else f"{v:.4g}"  # noqa: E731
        delta = "" if d.reference is None or d.current is None else f"{d.current - d.reference:+.4g}"
        lines.append(f"{d.suite + '/' + d.method:<24} {d.category:<10} {d.statistic:<15} {fmt(d.reference):>10} "
                     f"{fmt(d.current):>10} {delta:>9} {d.tolerance:>6g}")
    return "\n".join(lines)


def write_reference(path: Path, suite_name: str, suite: dict, results: dict, tolerances: dict) -> None:
    """Write (merge per method) a suite's reference JSON."""
    old = json.loads(path.read_text()) if path.is_file() else {}
    metrics = dict(old.get("metrics", {}))
    metrics.update(results)
    doc = {"suite": suite_name, "dataset": suite["dataset"], "protocol": suite["protocol"],
           "seed": int(suite.get("seed", 0)), "overrides": list(suite.get("overrides") or []),
           "method_overrides": suite.get("method_overrides") or {}, "tolerances": tolerances,
           "metrics": {m: metrics[m] for m in sorted(metrics)}}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, indent=1, sort_keys=False, allow_nan=True) + "\n")


def main(argv: list[str] | None = None) -> int:
    """``bench regress [--config FILE] [--suite S] [--methods a,b] [--update] [--keep DIR]``."""
    ap = argparse.ArgumentParser(prog="bench regress", description="CI regression against committed reference metrics.")
    ap.add_argument("--config", default=str(DEFAULT_CONFIG))
    ap.add_argument("--suite", action="append", help="run only these suites (repeatable)")
    ap.add_argument("--methods", default=None, help="comma-separated subset of each suite's methods")
    ap.add_argument("--update", action="store_true", help="rewrite the reference from this run")
    ap.add_argument("--keep", default=None, help="keep the run directories here (default: a temporary folder)")
    args = ap.parse_args(argv)
    try:
        cfg = load_config(args.config)
        tolerances = {s: float(cfg.get("tolerances", {}).get(s, 0.0)) for s in STATISTICS}
        names = args.suite or list(cfg["suites"])
        unknown = [s for s in names if s not in cfg["suites"]]
        if unknown:
            raise ConfigError(f"unknown suite(s) {unknown}; configured: {list(cfg['suites'])}")
        methods = args.methods.split(",") if args.methods else None
        all_diffs: list[Diff] = []
        notes: list[str] = []
        failures: list[str] = []
        with tempfile.TemporaryDirectory(prefix="catpose-regress-") as tmp:
            out_root = Path(args.keep) if args.keep else Path(tmp)
            if args.keep and out_root.exists() and any(out_root.iterdir()):
                # the runner would resume from old rows and compare results of older code
                raise ConfigError(f"--keep {out_root} is not empty; pass a new or empty folder")
            for name in names:
                suite = cfg["suites"][name]
                if suite.get("requires_shared_data") and not shared_data_dir().is_dir():
                    notes.append(f"{name}: skipped (no shared data at {shared_data_dir()})")
                    continue
                print(f"suite {name}: {suite['dataset']} / {suite['protocol']}, seed {suite.get('seed', 0)}")
                results, skipped = run_suite(name, suite, methods, out_root)
                notes += skipped
                ref_path = Path(suite["reference"])
                ref_path = ref_path if ref_path.is_absolute() else REPO / ref_path
                if args.update:
                    write_reference(ref_path, name, suite, results, tolerances)
                    notes.append(f"{name}: reference written to {ref_path} ({len(results)} methods)")
                    continue
                if not ref_path.is_file():
                    failures.append(f"{name}: no reference file {ref_path}; run `bench regress --update` and commit it")
                    continue
                reference = json.loads(ref_path.read_text()).get("metrics", {})
                diffs, more = compare(name, reference, results, tolerances, list(results))
                all_diffs += diffs
                notes += more
    except CatposeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for n in notes:
        print(f"note: {n}")
    table = format_failures(all_diffs)
    n_bad = sum(not d.ok for d in all_diffs)
    if table or failures:
        print("\nREGRESSION: statistics outside tolerance\n" + table if table else "", file=sys.stderr)
        for f in failures:
            print(f"REGRESSION: {f}", file=sys.stderr)
        print(f"\n{n_bad} of {len(all_diffs)} statistics differ; if the change is intended run "
              "`bench regress --update` and commit results/reference/", file=sys.stderr)
        return 1
    if not args.update:
        print(f"regress: {len(all_diffs)} statistics within tolerance")
    return 0
