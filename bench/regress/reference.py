"""A regression suite's reference (``results/reference/<suite>.json``): its per-sample answers, each
flagged *chaotic* or not, and their aggregates, written by ``bench regress --update`` and read by the
gate (:mod:`catpose.bench.regress.run_suites`).

Chaos detection: besides the nominal run, every method runs once on inputs perturbed by
``gate.perturbation`` (golden inputs only) and once in a child process per other code path of the
numerical libraries this CPU can take (:func:`other_code_paths`); a sample that any of them moves by
more than ``gate.chaos_deg`` is chaotic (reported by the gate, never failed on).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from catpose.bench.regress.regress_gate import Gate, aggregates, estimate_distance_deg
from catpose.errors import CatposeError, ConfigError

FORMAT = 2


def other_code_paths() -> dict[str, dict[str, str]]:
    """The code paths of :func:`~catpose.bench.run.environment.numeric_variants` that differ from
    this process's own (a variant already in effect is left out); without AVX2, another
    OpenBLAS kernel and torch's default kernels."""
    from catpose.bench.run.environment import numeric_variants, numpy_blas_kernel

    variants = numeric_variants() or {
        "other-kernel": {"OPENBLAS_CORETYPE": "Sandybridge"},
        "torch-default": {"ATEN_CPU_CAPABILITY": "default"},
    }
    kernel = numpy_blas_kernel()
    out = {}
    for name, env in variants.items():
        if all(os.environ.get(k) == v for k, v in env.items()):
            continue
        if set(env) == {"OPENBLAS_CORETYPE"} and env["OPENBLAS_CORETYPE"] == kernel:
            continue
        out[name] = env
    return out


def build_reference(suite, methods: Sequence[str], gate: Gate, config: Path, jobs: int = 1, log=print) -> dict:
    """Run, perturb, re-run under every other code path of this CPU, and return the reference
    entries per method (each sample records how far each of them moved it)."""
    from catpose.bench.regress.run_suites import map_jobs

    t0 = time.perf_counter()
    others = {}  # {code path: {method: {sample_id: slim row}}}, from `bench regress --emit-estimates` in a child
    for name, env in other_code_paths().items():
        shown = " ".join(f"{k}={v}" for k, v in env.items())
        log(f"  chaos detection under {name}: {shown}")
        with tempfile.TemporaryDirectory(prefix="catpose-regress-") as tmp:
            out = Path(tmp) / "estimates.json"
            cmd = [
                sys.executable,
                "-m",
                "catpose.bench.regress.run_suites",
                "--config",
                str(config),
                "--suite",
                suite.name,
            ]
            cmd += ["--methods", ",".join(methods), "--emit-estimates", str(out), "--jobs", str(jobs)]
            proc = subprocess.run(cmd, env=dict(os.environ, **env), capture_output=True, text=True)
            if proc.returncode != 0:
                why = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else proc.returncode
                raise CatposeError(f"run under another code path failed ({shown}): {why}")
            others[name] = json.loads(out.read_text())
    tasks = [(suite, m, 0.0) for m in methods]
    if suite.inputs is not None:  # live inputs already differ in their last bits across kernels
        tasks += [(suite, m, gate.perturbation) for m in methods]
    results = map_jobs(tasks, jobs)
    log(f"  {suite.name}: {len(tasks) + len(others) * len(methods)} runs in {time.perf_counter() - t0:.1f} s")
    out = {}
    for i, m in enumerate(methods):
        nominal = results[i]
        shaken = results[len(methods) + i] if suite.inputs is not None else {}
        for sid, r in nominal.items():
            d_p = estimate_distance_deg(r, shaken[sid]) if sid in shaken else float("nan")
            d_k = {name: estimate_distance_deg(r, o[m][sid]) for name, o in others.items() if sid in o.get(m, {})}
            r["perturbation_moves_deg"] = None if math.isnan(d_p) else round(d_p, 4)
            r["code_path_moves_deg"] = {name: round(d, 4) for name, d in d_k.items()}
            r["chaotic"] = bool(max([0.0 if math.isnan(d_p) else d_p, *d_k.values()]) > gate.chaos_deg)
        stable = {sid for sid, r in nominal.items() if not r["chaotic"]}
        out[m] = {"samples": nominal, "aggregates": aggregates(nominal, stable, gate)}
        n_ch = len(nominal) - len(stable)
        log(
            f"  {suite.name}/{m}: {n_ch} of {len(nominal)} samples chaotic"
            + (f": {', '.join(sorted(set(nominal) - stable))}" if n_ch else "")
        )
    return out


def write_reference(suite, entries: dict, gate: Gate, repo: Path) -> None:
    """Merge ``entries`` (per method) into the suite's reference file with this environment
    (``repo``: the folder the inputs' path is written relative to)."""
    from catpose import atomic
    from catpose.bench.run.environment import environment

    old = read_reference(suite.reference) if suite.reference.is_file() else {}
    methods = dict(old.get("methods", {})) if old.get("format") == FORMAT else {}
    methods.update(entries)
    doc = {
        "format": FORMAT,
        "suite": suite.name,
        "dataset": suite.dataset,
        "protocol": suite.protocol,
        "seed": suite.seed,
        "overrides": suite.overrides,
        "method_overrides": suite.method_overrides,
        "inputs": None if suite.inputs is None else str(suite.inputs.relative_to(repo)),
        "gate": gate.__dict__ | {"accuracy_thresholds": list(gate.accuracy_thresholds)},
        "environment": environment(),
        "methods": {m: methods[m] for m in sorted(methods)},
    }
    atomic.write_text(suite.reference, json.dumps(doc, indent=1, allow_nan=True) + "\n")


def read_reference(path: Path) -> dict:
    """A suite's reference JSON; a cut-off or damaged file is a :class:`ConfigError` in one line
    (exit status 2: exit 1 means the gate found a regression, never a file it cannot read)."""
    fix = "restore it (git checkout -- it) or rewrite it with `bench regress --update`"
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ConfigError(
            f"reference {path} cannot be read ({type(e).__name__}: {' '.join(str(e).split())[:80]}); {fix}"
        ) from None
    if not isinstance(doc, dict):
        raise ConfigError(f"reference {path} is not a JSON object; {fix}")
    return doc
