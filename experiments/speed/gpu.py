"""Solver-only GPU check of ours' batched IRLS solver: needs torch and NumPy, nothing else.

``bench perf --set optimiser.device=cuda`` times the whole pipeline but needs the project's full
environment (Open3D, Hydra) on the GPU machine. This script times only the part that runs on the
GPU, on problems of the default size (``m = 18`` candidates, ``n = 32`` input keypoints, ``2n``
template keypoints per candidate, 5 + 5 iterations), with ``B`` problems per launch, and checks the
GPU answer (float32) against the CPU float64 answer of the same code. It runs from a bare checkout,
without installing the project::

    python3 experiments/speed/gpu.py --out $OUT/gpu_solver.csv          # cuda if available, and cpu
    python3 experiments/speed/gpu.py --devices cpu --batches 1,16        # what the tests run

Output: one row per (device, batch): milliseconds per problem (median over ``--repeat`` timed
launches after two warm-ups, CUDA synchronised), problems per second, the largest rotation
difference to the CPU float64 answer (degrees) and the device name.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import time
from pathlib import Path

import numpy as np


def _irls():
    try:
        from catpose.methods.ours import irls
    except ImportError:  # a bare checkout: catpose from src/, its methods/ beside it, nothing installed
        repo = Path(__file__).resolve().parents[2]
        for name in [m for m in sys.modules if m == "catpose" or m.startswith("catpose.")]:
            del sys.modules[name]  # a half-imported catpose from elsewhere
        sys.path.insert(0, str(repo / "src"))
        import catpose

        catpose.__path__.append(str(repo))  # catpose.methods is the checkout's methods/
        from catpose.methods.ours import irls
    return irls


def make_problems(count: int, m: int = 18, n: int = 32, seed: int = 0) -> list:
    """``count`` problems shaped like ours' default: input keypoints (n, 3), per candidate noisy
    rigid copies plus distractors (m, 2n, 3), a peaked affinity (m, n, 2n), identity starts."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        p = rng.normal(size=(n, 3)) * 0.4
        R = np.linalg.qr(rng.normal(size=(m, 3, 3)))[0]
        R *= np.sign(np.linalg.det(R))[:, None, None]
        q = np.concatenate(
            [np.einsum("mij,nj->mni", R, p) + rng.normal(size=(m, n, 3)) * 0.02, rng.normal(size=(m, n, 3)) * 0.5],
            axis=1,
        )
        A = rng.random((m, n, 2 * n)) * 0.3
        A[:, np.arange(n), np.arange(n)] += 1.0
        A /= A.sum(2, keepdims=True)
        out.append((p, q, A, np.tile(np.eye(4), (m, 1, 1))))
    return out


def dump_inputs(path: Path, golden: Path | None = None) -> int:
    """Write the solver inputs of ours on real problems (the regression suite's golden inputs:
    24 rendered views of 8 categories) to ``path`` (.npz): per problem ``p{i}`` (n, 3) input
    keypoints, ``q{i}`` (m, 2n, 3) partial-template keypoints, ``A{i}`` (m, n, 2n) affinities,
    ``T{i}`` (m, 4, 4) SVD starts. Needs the project installed (Open3D, Hydra); the file then
    travels to a GPU machine that has only torch and NumPy. Returns the number of problems."""
    from catpose.bench.regress.golden import read_golden
    from catpose.bench.run.config import compose_and_build

    golden = golden or Path(__file__).resolve().parents[2] / "results" / "reference" / "synthetic_inputs.npz"
    _, ((_, ours),) = compose_and_build(["method=ours"], ("method",))
    arrays = {}
    samples = read_golden(golden)
    for i, s in enumerate(samples):
        x = ours.prepare(s.problem, {})
        arrays.update({f"p{i}": x.keypoints, f"q{i}": x.P_t, f"A{i}": x.A, f"T{i}": x.T_svd})
    from catpose import atomic

    with atomic.atomic_path(path) as tmp:
        np.savez_compressed(tmp, **arrays)
    return len(samples)


def load_inputs(path: Path) -> list:
    """The problems written by :func:`dump_inputs`."""
    with np.load(path) as z:
        n = sum(k.startswith("p") for k in z.files)
        return [tuple(np.asarray(z[f"{k}{i}"], np.float64) for k in "pqAT") for i in range(n)]


def _rot_diff_deg(Ta: np.ndarray, Tb: np.ndarray) -> float:
    c = (np.einsum("bij,bij->b", Ta[:, :3, :3], Tb[:, :3, :3]) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1, 1))).max())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="perf_gpu", description=__doc__.split("\n\n")[0])
    ap.add_argument("--devices", default=None, help="comma-separated (default: cuda if available, and cpu)")
    ap.add_argument("--batches", default="1,16,64", help="problems per launch (default 1,16,64)")
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--iterations", type=int, default=5, help="IRLS iterations per stage (default 5)")
    ap.add_argument("--out", default=None, help="CSV path")
    ap.add_argument(
        "--inputs",
        default=None,
        help="real solver inputs (.npz from --dump-inputs) instead of "
        "generated problems (cycled to fill larger batches)",
    )
    ap.add_argument(
        "--dump-inputs",
        default=None,
        help="write ours' solver inputs on the golden problems to this .npz and exit (needs the installed project)",
    )
    args = ap.parse_args(argv)
    if args.dump_inputs:
        print(f"perf_gpu: {dump_inputs(Path(args.dump_inputs))} problems written to {args.dump_inputs}")
        return 0
    try:
        import torch
    except ImportError:  # the torch extra: one line naming it, as catpose.extras words it
        print(
            "perf_gpu: error: the solver check needs torch: pip install 'catpose[torch]' (or pip install torch)",
            file=sys.stderr,
        )
        return 2

    irls = _irls()
    torch.set_num_threads(1)
    devices = args.devices.split(",") if args.devices else (["cuda"] if torch.cuda.is_available() else []) + ["cpu"]
    if "cuda" in devices and not torch.cuda.is_available():
        print("perf_gpu: error: --devices cuda but torch has no CUDA device here", file=sys.stderr)
        return 2
    batches = [int(b) for b in args.batches.split(",")]
    if args.inputs:  # the real problems, cycled for batches larger than their count
        real = load_inputs(Path(args.inputs))
        problems = [real[i % len(real)] for i in range(max(batches))]
    else:
        problems = make_problems(max(batches))
    stages = ("pose", "joint")
    reference = irls.solve_many(problems, stages, max_iter=args.iterations, tol=1e-4, device="cpu", dtype="float64")
    rows = []
    for dev in devices:
        dtype = "float32" if dev == "cuda" else "float64"
        name = torch.cuda.get_device_name(0) if dev == "cuda" else "cpu (1 torch thread)"
        for b in batches:
            batch = problems[:b]

            def once():
                res = irls.solve_many(batch, stages, max_iter=args.iterations, tol=1e-4, device=dev, dtype=dtype)
                if dev == "cuda":
                    torch.cuda.synchronize()
                return res

            for _ in range(2):
                res = once()
            times = []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                once()
                times.append(time.perf_counter() - t0)
            ms = statistics.median(times) * 1e3 / b
            diff = max(_rot_diff_deg(r[0], ref[0]) for r, ref in zip(res, reference))
            rows.append(
                {
                    "problems": f"real ({len(real)} golden views, cycled)" if args.inputs else "generated",
                    "device": dev,
                    "batch": b,
                    "ms_per_problem": round(ms, 4),
                    "problems_per_s": round(1e3 / ms, 1),
                    "max_rot_diff_deg_vs_cpu64": round(diff, 5),
                    "dtype": dtype,
                    "name": name,
                    "torch": torch.__version__,
                }
            )
            print(rows[-1], flush=True)
    if args.out:
        out = Path(args.out)  # a bare checkout has no catpose.atomic: the same temp file + os.replace here
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(f".{out.name}.tmp")
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
