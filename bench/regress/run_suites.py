"""``bench regress``: a per-sample regression gate for ours and the baselines.

Each suite of ``configs/regress/default.yaml`` is a fixed set of problems (the embedded suite's
from committed golden inputs, :mod:`catpose.bench.regress.golden`) and a list of methods, checked
against ``results/reference/<suite>.json`` by the rules of :mod:`catpose.bench.regress.regress_gate`.

    bench regress                          # every suite (shared-data suites only when present)
    bench regress --suite synthetic --methods icp,ours
    bench regress --update                 # after an intended change; commit results/reference/
    bench regress --write-inputs           # re-render the golden inputs (changes every answer)"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from catpose import kernel_threads
from catpose.bench.regress.reference import FORMAT, build_reference, read_reference, write_reference
from catpose.bench.regress.regress_gate import Finding, Gate, compare_method, to_float
from catpose.bench.run.config import compose, shared_data_dir
from catpose.errors import CatposeError, ConfigError, command_error

REPO = Path(__file__).resolve().parents[2]
DEFAULT_CONFIG = REPO / "configs" / "regress" / "default.yaml"


# --------------------------------------------------------------------------------------------
# configuration


@dataclass
class Suite:
    """One configured suite."""

    name: str
    methods: list[str]
    reference: Path
    dataset: str = "synthetic"
    protocol: str = "gt_model"
    seed: int = 0
    overrides: list[str] = field(default_factory=list)
    method_overrides: dict[str, list[str]] = field(default_factory=dict)
    inputs: Path | None = None
    requires_shared_data: bool = False


def _repo_path(p: str | Path) -> Path:
    p = Path(p)
    return p if p.is_absolute() else REPO / p


def load_config(path: str | Path = DEFAULT_CONFIG) -> tuple[Gate, dict[str, Suite]]:
    """The gate thresholds and the suites (raises :class:`ConfigError` naming the key)."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"regress config {path} does not exist; pass --config FILE")
    try:
        cfg = yaml.safe_load(path.read_text(errors="replace")) or {}
    except yaml.YAMLError:
        cfg = {}
    if not isinstance(cfg, dict) or not isinstance(cfg.get("suites"), dict) or not cfg["suites"]:
        raise ConfigError(f"{path} has no 'suites' mapping; see configs/regress/default.yaml")
    g = dict(cfg.get("gate") or {})
    unknown = set(g) - set(Gate.__dataclass_fields__)
    if unknown:
        raise ConfigError(f"{path}: unknown gate keys {sorted(unknown)}; valid: {sorted(Gate.__dataclass_fields__)}")
    if "accuracy_thresholds" in g:
        g["accuracy_thresholds"] = tuple(float(x) for x in g["accuracy_thresholds"])
    gate = Gate(**g)
    suites = {}
    for name, s in cfg["suites"].items():
        for key in ("dataset", "protocol", "methods", "reference"):
            if key not in s:
                raise ConfigError(f"{path}: suite {name!r} lacks {key!r}")
        suites[name] = Suite(
            name=name,
            methods=list(s["methods"]),
            reference=_repo_path(s["reference"]),
            dataset=str(s["dataset"]),
            protocol=str(s["protocol"]),
            seed=int(s.get("seed", 0)),
            overrides=[str(o) for o in s.get("overrides") or []],
            method_overrides={k: list(v) for k, v in (s.get("method_overrides") or {}).items()},
            inputs=_repo_path(s["inputs"]) if s.get("inputs") else None,
            requires_shared_data=bool(s.get("requires_shared_data", False)),
        )
    return gate, suites


# --------------------------------------------------------------------------------------------
# running


def _compose(suite: Suite, method: str | None) -> Any:
    shared = str(shared_data_dir())
    overrides = [
        f"dataset={suite.dataset}",
        f"protocol={suite.protocol}",
        f"seed={suite.seed}",
        *[o.replace("{shared_data}", shared) for o in suite.overrides],
    ]
    if method:
        overrides += [f"method={method}", *suite.method_overrides.get(method, [])]
    return compose(overrides)


def suite_samples(suite: Suite, transform: Callable | None = None) -> tuple[Any, Any, list[str]]:
    """(dataset, protocol, sample ids) of a suite: golden inputs when it has them, else its
    dataset and protocol built from config. ``transform`` maps each loaded sample (golden only)."""
    from catpose.bench.regress.golden import GoldenProtocol, read_golden
    from catpose.bench.run.build import build_dataset, build_from_config

    if suite.inputs is not None:
        protocol = GoldenProtocol(read_golden(suite.inputs), transform)
        return protocol, protocol, protocol.sample_ids()
    cfg = _compose(suite, None)
    dataset = build_dataset(cfg.dataset)
    _, protocol = build_from_config(cfg.protocol, "protocol")
    return dataset, protocol, protocol.sample_ids(dataset)


def slim_rows(suite: Suite, method: str, perturbation: float = 0.0) -> dict[str, dict]:
    """{sample_id: slim row} of one method on a suite (every problem registered as ``bench run``
    registers a sample); with ``perturbation`` > 0 every golden
    input is first perturbed by that relative amount (see :func:`catpose.bench.regress.golden.perturbed`).
    A top-level function, so that worker processes can run it."""
    from catpose.bench.run.build import build_from_config
    from catpose.bench.run.sample_run import run_one

    transform = None
    if perturbation > 0:
        from catpose.bench.regress.golden import perturbed
        from catpose.geometry import stable_seed

        def transform(s):
            return perturbed(s, perturbation, stable_seed("regress-perturb", s.problem.sample_id))

    cfg = _compose(suite, method)
    kernel_threads.set_threads(cfg.get("threads"))
    _, built = build_from_config(cfg.method, "method")
    dataset, protocol, ids = suite_samples(suite, transform)
    base = {"method": method, "dataset": suite.dataset, "protocol": suite.protocol, "seed": suite.seed}
    return {sid: _slim(run_one(built, protocol, dataset, sid, base, suite.seed)) for sid in ids}


def map_jobs(tasks: Sequence[tuple], jobs: int) -> list:
    """``[slim_rows(*t) for t in tasks]``, in ``jobs`` worker processes when ``jobs`` > 1, each on
    one thread (:func:`_one_thread`; results do not depend on threads or workers, only the wall
    time does)."""
    if jobs <= 1 or len(tasks) <= 1:
        return [slim_rows(*t) for t in tasks]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=ctx, initializer=_one_thread) as ex:
        return list(ex.map(slim_rows, *zip(*tasks)))


def _one_thread() -> None:
    """A gate worker's ``threads=auto`` is 1: the workers are the parallelism."""
    os.environ["OMP_NUM_THREADS"] = "1"


def _slim(row: dict) -> dict:
    """The part of a runner row the reference keeps."""
    floats = lambda v: None if v is None else [float(x) for x in list(v)]  # noqa: E731
    return {
        "category": row.get("category"),
        "status": row.get("status"),
        "error": row.get("error") or "",
        "err_deg": to_float(row.get("err_deg")),
        "trans_err": to_float(row.get("trans_err")),
        **{k: floats(row.get(k)) for k in ("T_est", "T_gt", "symmetry_axis")},
        "symmetries": [floats(S) for S in row.get("symmetries") or []],
    }


def write_inputs(suite: Suite, log=print) -> None:
    """Render the suite's problems from its dataset config and freeze them into its ``inputs``
    file (golden inputs)."""
    from catpose.bench.regress.golden import write_golden

    dataset, protocol, ids = suite_samples(dataclasses.replace(suite, inputs=None))
    samples = [protocol.load(dataset, sid) for sid in ids]
    write_golden(suite.inputs, suite.name, suite.overrides, samples)
    log(
        f"  {suite.name}: {len(samples)} problems written to {suite.inputs} "
        f"({suite.inputs.stat().st_size / 1024:.0f} KiB)"
    )


# --------------------------------------------------------------------------------------------
# the command


def available_methods(suite: Suite, wanted: Sequence[str] | None, notes: list[str]) -> list[str]:
    """The methods of ``suite`` (or ``wanted``) whose config exists and builds (module and optional
    dependencies import); each other one is skipped with a note saying why."""
    from catpose.bench.run.build import build_from_config

    methods = []
    for m in wanted or suite.methods:
        why = None
        if not (REPO / "configs" / "method" / f"{m}.yaml").is_file():
            why = f"no configs/method/{m}.yaml"
        else:
            try:
                build_from_config(_compose(suite, m).method, "method")
            except (CatposeError, ImportError) as e:
                why = " ".join(str(e).split())
        if why:
            notes.append(f"{suite.name}/{m}: skipped ({why})")
        else:
            methods.append(m)
    return methods


def check_suite(
    suite: Suite, methods: Sequence[str], gate: Gate, jobs: int = 1, log=print
) -> tuple[list[Finding], list[str]]:
    """Run and judge one suite against its reference; (findings, notes)."""
    from catpose.bench.run.environment import differences, environment

    if not suite.reference.is_file():
        what = f"no reference file {suite.reference}; run `bench regress --update` and commit it"
        return [Finding("-", suite.name, what, True)], []
    doc = read_reference(suite.reference)
    if doc.get("format") != FORMAT:
        what = f"{suite.reference} is of an older format; run `bench regress --update`"
        return [Finding("-", suite.name, what, True)], []
    findings, notes = [], []
    for m in methods:
        if m not in doc["methods"]:
            notes.append(f"{suite.name}/{m}: no reference yet (run `bench regress --update` and commit it)")
    methods = [m for m in methods if m in doc["methods"]]
    t0 = time.perf_counter()
    results = map_jobs([(suite, m, 0.0) for m in methods], jobs)
    log(f"  {suite.name}: {len(methods)} methods in {time.perf_counter() - t0:.1f} s")
    for m, current in zip(methods, results):
        found = compare_method(m, doc["methods"][m], current, gate)
        findings += found
        n_ch = sum(bool(r.get("chaotic")) for r in doc["methods"][m]["samples"].values())
        log(
            f"  {suite.name}/{m}: {len(current)} samples ({n_ch} chaotic), "
            f"{sum(f.fails for f in found)} failing, {sum(not f.fails for f in found)} noted"
        )
    if any(f.fails for f in findings):
        diff = differences(doc.get("environment"), environment())
        notes += [f"{suite.name}: environment differs from the reference's: {d}" for d in diff] or [
            f"{suite.name}: environment is the reference's"
        ]
    return findings, notes


def main(argv: list[str] | None = None) -> int:
    """``bench regress [--config F] [--suite S] [--methods a,b] [--update | --write-inputs]``."""
    ap = argparse.ArgumentParser(
        prog="bench regress", description="Per-sample regression gate against committed references."
    )
    ap.add_argument("--config", default=str(DEFAULT_CONFIG))
    ap.add_argument("--suite", action="append", help="run only these suites (repeatable)")
    ap.add_argument("--methods", default=None, help="comma-separated subset of each suite's methods")
    ap.add_argument("--update", action="store_true", help="rewrite the reference (with chaos detection)")
    ap.add_argument("--write-inputs", action="store_true", help="re-render the golden inputs of the suites")
    ap.add_argument(
        "--jobs",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="worker processes, one method each (results do not depend on it)",
    )
    ap.add_argument("--emit-estimates", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    try:
        from catpose.bench.run.environment import numpy_blas_kernel

        gate, suites = load_config(args.config)
        names = args.suite or list(suites)
        unknown = [s for s in names if s not in suites]
        if unknown:
            raise ConfigError(f"unknown suite(s) {unknown}; configured: {list(suites)}")
        wanted = [m.strip() for m in args.methods.split(",") if m.strip()] if args.methods is not None else None
        if wanted is not None:  # a name no selected suite lists would be skipped and the gate "pass"
            known = sorted({m for n in names for m in suites[n].methods})
            unknown = [m for m in wanted if m not in known]
            if unknown or not wanted:
                raise ConfigError(
                    f"--methods {','.join(unknown) or repr(args.methods)}: not a method of the suites run "
                    f"({', '.join(names)}); choose among {', '.join(known)}"
                )
        checked = 0
        findings: list[Finding] = []
        notes: list[str] = []
        emitted: dict = {}
        for name in names:
            suite = suites[name]
            if suite.requires_shared_data and not shared_data_dir().is_dir():
                notes.append(f"{name}: skipped (no shared data at {shared_data_dir()})")
                continue
            if wanted is not None and not any(m in suite.methods for m in wanted):
                notes.append(f"{name}: skipped (none of --methods {','.join(wanted)} is among its methods)")
                continue
            if args.write_inputs:
                if suite.inputs is not None:
                    write_inputs(suite)
                continue
            methods = available_methods(suite, wanted, notes)
            if args.emit_estimates:
                emitted = dict(zip(methods, map_jobs([(suite, m, 0.0) for m in methods], args.jobs)))
                continue
            print(
                f"suite {name}: {suite.dataset} / {suite.protocol}, seed {suite.seed}, "
                f"{'golden inputs' if suite.inputs else 'rendered here'}, BLAS kernel {numpy_blas_kernel()}"
            )
            if args.update:
                write_reference(suite, build_reference(suite, methods, gate, Path(args.config), args.jobs), gate, REPO)
                notes.append(f"{name}: reference written to {suite.reference}")
                continue
            found, more = check_suite(suite, methods, gate, args.jobs)
            findings += found
            notes += more
            checked += sum(not any(n.startswith(f"{name}/{m}: no reference") for n in more) for m in methods)
        if args.emit_estimates:
            from catpose import atomic

            atomic.write_text(args.emit_estimates, json.dumps(emitted))
            return 0
    except CatposeError as e:
        print(command_error("regress", e), file=sys.stderr)
        return 2
    for f in findings:
        if not f.fails:
            print(f"moved: {f.method} {f.where}: {f.what}")
    for n in notes:
        print(f"note: {n}")
    bad = [f for f in findings if f.fails]
    if bad:
        print("\nREGRESSION:", file=sys.stderr)
        for f in bad:
            print(f"  {f.method} {f.where}: {f.what}", file=sys.stderr)
        print(
            f"\n{len(bad)} failing finding(s); if the change is intended run `bench regress --update` "
            "and commit results/reference/",
            file=sys.stderr,
        )
        return 1
    if not (args.update or args.write_inputs):
        if checked == 0:  # every suite or method skipped: nothing passed
            print(
                command_error("regress", "nothing was checked (every suite or method was skipped, see the notes)"),
                file=sys.stderr,
            )
            return 2
        print(f"regress: passed ({len(findings)} samples moved within what the gate allows; {checked} methods checked)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
