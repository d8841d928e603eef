"""``python experiments/speed/first_sample.py``: seconds to the first registration of a template in a new process,
with the template cache cold and warm.

Each measurement is a fresh Python process (``python experiments/speed/first_sample.py --child``)
that does what ``bench run`` does for its first samples, timing each phase:

- ``import_s``: importing the runner's modules; ``build_s``: building the method from
  ``configs/method/<name>.yaml``; ``load_s``: building the dataset and protocol and loading the
  first sample of each of ``--templates`` templates (round-robin over categories as ``bench perf``);
- ``jit_start_s``: numba's once-per-process start-up (loading its compiled kernels from numba's
  own on-disk cache and its lowering registries: the first call of any compiled kernel pays it,
  whatever the template), timed on its own so that the template's share is seen;
- per template, ``first_s``: its first registration (building or loading its dictionary, its
  descriptors, its gravity hypotheses, its ray caster, then registering), and ``second_s``: the
  same problem again (everything in memory).

``cold``: the process starts with an empty ``CATPOSE_CACHE_DIR`` (a new temporary folder); ``warm``:
a second process with the folder the cold one filled, the case of a second run or a second worker.
Numba's own cache is warm in both (it is filled once per installation, by the first run). Each
pair is repeated ``--repeat`` times with a new folder; the table gives every run and the medians.
Seconds are wall-clock on a shared machine: the load average is printed with them.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from catpose.errors import ConfigError

PHASES = ("import_s", "build_s", "load_s", "jit_start_s")
TIMES = ("first_s", "second_s", "first_cpu_s", "second_cpu_s")


def child(argv: list[str]) -> int:
    """The measured process: prints one JSON object with its phases and per-template seconds."""
    t0 = time.perf_counter()
    ap = argparse.ArgumentParser()
    ap.add_argument("--dataset")
    ap.add_argument("--root", default=None)
    ap.add_argument("--method")
    ap.add_argument("--templates", type=int)
    ap.add_argument("--seed", type=int)
    a = ap.parse_args(argv)
    import torch  # noqa: F401 - its import is part of the measured start

    from catpose import kernel_threads
    from catpose.bench.perf.registration import build_method
    from catpose.bench.run.config import compose_and_build
    from catpose.bench.run.sample_run import seed_everything
    from catpose.geometry import stable_seed

    kernel_threads.set_threads(1)  # one thread, torch's too: the work's latency, not a pool's start
    out: dict = {"import_s": time.perf_counter() - t0}
    t = time.perf_counter()
    method = build_method(a.method, a.seed)
    out["build_s"] = time.perf_counter() - t
    t = time.perf_counter()
    overrides = [f"dataset={a.dataset}", "protocol=gt_model", f"seed={a.seed}"]
    overrides += [f"dataset.root={a.root}"] if a.root else []
    _, ((name, ds), (_, protocol)) = compose_and_build(overrides, ("dataset", "protocol"))
    firsts, seen = [], set()
    for sample_id in protocol.sample_ids(ds):  # the first sample of each of the first templates, in run order
        p = protocol.load(ds, sample_id).problem
        if p.template.template_id not in seen:
            seen.add(p.template.template_id)
            firsts.append(p)
        if len(firsts) == a.templates:
            break
    out["load_s"] = time.perf_counter() - t
    out["source"] = f"{name} (gt_model, seed {a.seed})"
    t, c = time.perf_counter(), time.process_time()
    _jit_start()
    out["jit_start_s"], out["jit_start_cpu_s"] = time.perf_counter() - t, time.process_time() - c
    out["templates"] = []
    for p in firsts:
        wall, cpu = [], []
        for _ in range(2):
            seed_everything(stable_seed(a.seed, p.sample_id))
            t, c = time.perf_counter(), time.process_time()
            method.register(p)
            wall.append(time.perf_counter() - t)
            cpu.append(time.process_time() - c)
        out["templates"].append(
            {
                "template": p.template.template_id,
                "first_s": wall[0],
                "second_s": wall[1],
                "first_cpu_s": cpu[0],
                "second_cpu_s": cpu[1],
            }
        )
    print(json.dumps(out))
    return 0


def _jit_start() -> None:
    """Call one compiled kernel on a tiny input: numba's per-process start-up, nothing of a template."""
    import numpy as np

    from catpose.methods.keypoints import farthest_point_indices

    farthest_point_indices(np.random.default_rng(0).normal(size=(8, 3)), 2)


def _run_child(args: argparse.Namespace, cache: Path) -> dict:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--dataset", args.dataset]
    cmd += ["--method", args.methods.split(",")[0], "--templates", str(args.templates), "--seed", str(args.seed)]
    if args.root:
        cmd += ["--root", str(args.root)]
    env = dict(os.environ, CATPOSE_CACHE_DIR=str(cache))
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=3600)
    if r.returncode != 0:
        raise ConfigError(f"first_sample: the measured process failed: {r.stderr.strip()[-500:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def measure(args: argparse.Namespace) -> list[dict]:
    """Rows (state, run, phase seconds, per-template first and second seconds) of ``--repeat``
    cold-then-warm pairs."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="catpose-first-") as tmp:
        for run in range(args.repeat):
            cache = Path(tmp) / f"cache{run}"
            for state in ("cold", "warm"):
                m = _run_child(args, cache)
                for k, tpl in enumerate(m["templates"]):
                    rows.append(
                        {
                            "state": state,
                            "run": run,
                            "template_order": k + 1,
                            "template": tpl["template"],
                            **{ph: m[ph] for ph in PHASES},
                            "jit_start_cpu_s": m["jit_start_cpu_s"],
                            **{k: tpl[k] for k in TIMES},
                            "source": m["source"],
                        }
                    )
    return rows


def medians(rows: list[dict]) -> list[dict]:
    """Per state and template order: the median of each measure over the runs. ``first_sample_s``
    (numba's start-up + the first template's first registration, or a later template's first
    registration) is what a new process waits for its first pose of that template once the
    method is built and the sample loaded; ``*_cpu_s`` are the process' CPU seconds of the same
    spans (what a busy machine's waiting for a core leaves out)."""
    out = []
    keys = sorted({(r["state"], r["template_order"]) for r in rows}, key=lambda k: (k[0] != "cold", k[1]))
    for state, order in keys:
        group = [r for r in rows if r["state"] == state and r["template_order"] == order]
        med = {c: statistics.median(r[c] for r in group) for c in (*PHASES, "jit_start_cpu_s", *TIMES)}
        jit, jit_cpu = (med["jit_start_s"], med["jit_start_cpu_s"]) if order == 1 else (0.0, 0.0)
        out.append(
            {
                "state": state,
                "template_order": order,
                "template": group[0]["template"],
                "runs": len(group),
                "jit_start_s": jit,
                "first_s": med["first_s"],
                "second_s": med["second_s"],
                "first_sample_s": statistics.median(
                    r["first_s"] + (r["jit_start_s"] if order == 1 else 0.0) for r in group
                ),
                "first_sample_cpu_s": statistics.median(
                    r["first_cpu_s"] + (r["jit_start_cpu_s"] if order == 1 else 0.0) for r in group
                ),
                "second_cpu_s": med["second_cpu_s"],
                **{c: med[c] for c in PHASES[:3]},
            }
        )
    return out


def main(argv: list[str]) -> int:
    if argv[:1] == ["--child"]:
        return child(argv[1:])
    from tabulate import tabulate

    from catpose import atomic

    ap = argparse.ArgumentParser(prog="python experiments/speed/first_sample.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", default="synthetic")
    ap.add_argument("--root", default=None, help="dataset root (sets dataset.root)")
    ap.add_argument("--methods", default="ours", help="the method config (the first name given)")
    ap.add_argument("--templates", type=int, default=3, help="templates per process (default 3)")
    ap.add_argument("--repeat", type=int, default=3, help="cold-then-warm pairs (default 3)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="CSV path (default outputs/perf/first-sample-<dataset>.csv)")
    args = ap.parse_args(argv)
    if args.templates < 1 or args.repeat < 1:
        raise ConfigError("--templates and --repeat must be at least 1")
    load_before = os.getloadavg()[0]
    rows = measure(args)
    load_after = os.getloadavg()[0]
    table = medians(rows)
    method = args.methods.split(",")[0]
    head = (
        f"**First sample of a template in a new process**: {method} on {rows[0]['source']}; {args.repeat} cold-then-warm "
        f"process pairs, medians (s wall-clock; cpu: the process' CPU seconds); load average {load_before:.1f} "
        f"before, {load_after:.1f} after on {os.cpu_count()} CPUs"
    )
    shown = ["state", "template_order", "template", "jit_start_s", "first_s", "second_s", "first_sample_s"]
    shown += ["first_sample_cpu_s", "second_cpu_s"]
    md = tabulate([{k: r[k] for k in shown} for r in table], headers="keys", tablefmt="github", floatfmt=".3f")
    print(head)
    print(md)
    out = Path(args.out) if args.out else Path("outputs") / "perf" / f"first-sample-{args.dataset}.csv"
    meta = {"method": method, "load_before": round(load_before, 2), "load_after": round(load_after, 2)}
    meta["cpus"] = os.cpu_count()
    for path, data in ((out, table), (out.with_name(out.stem + "_runs.csv"), rows)):
        import csv

        with atomic.atomic_write(path, newline="") as f:
            w = csv.DictWriter(f, fieldnames=[*data[0], *meta])
            w.writeheader()
            w.writerows(dict(r, **meta) for r in data)
    atomic.write_text(out.with_suffix(".md"), f"{head}\n\n{md}\n")
    print(f"\nwrote {out} (and {out.stem}_runs.csv, {out.stem}.md)")
    return 0


if __name__ == "__main__":  # python experiments/speed/first_sample.py [--child ...]
    from catpose.errors import CatposeError, command_error

    try:
        sys.exit(main(sys.argv[1:]))
    except CatposeError as e:  # a bad option: one line, exit 2
        print(command_error("first_sample", e), file=sys.stderr)
        sys.exit(2)
