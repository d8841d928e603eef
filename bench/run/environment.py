"""The software and hardware a run's numbers came from, and how two such records differ.

Last-bit floating-point differences between machines come from library versions and from the
code paths the libraries choose at run time for the CPU (OpenBLAS's kernel, NumPy's dispatched
loops, torch's CPU capability, numba's target CPU). Every ``run.json`` and every regression
reference records them, so that a result that moved can be traced to the code or to the machine;
:func:`numeric_variants` and :func:`portable_profile` name the settings that make this CPU
compute as others do.
"""

from __future__ import annotations

import contextlib
import os
import platform
from importlib import metadata
from typing import Any

from catpose.disk_cache import LIBRARIES, NUMERIC_ENV

#: the packages whose versions every run records: the numerical libraries (those the disk cache's
#: keys name) and Hydra; the variables of :data:`~catpose.disk_cache.NUMERIC_ENV` set are recorded too
PACKAGES = (*LIBRARIES, "hydra-core")
_CACHE: dict[str, Any] = {}


def _cpuinfo(*keys: str) -> str | None:
    """The value of the first ``/proc/cpuinfo`` line starting with one of ``keys`` (None elsewhere)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            return next((line.split(":", 1)[1].strip() for line in f if line.startswith(keys)), None)
    except OSError:
        return None


def cpu_flags() -> list[str]:
    """The vector extensions the CPU reports that decide BLAS kernels (avx, avx2, avx512f, ...)."""
    wanted = {"sse4_2", "avx", "avx2", "fma", "avx512f", "avx512_bf16", "amx_tile", "asimd", "sve"}
    return sorted(wanted & set((_cpuinfo("flags", "Features") or "").split()))


def blas_kernels() -> list[dict]:
    """The BLAS libraries loaded in this process with the kernel each chose (threadpoolctl)."""
    import numpy  # noqa: F401  (loads OpenBLAS so that threadpoolctl sees it)
    from threadpoolctl import threadpool_info

    out = []
    for lib in threadpool_info():
        if lib.get("user_api") != "blas":
            continue
        out.append(
            {k: lib.get(k) for k in ("internal_api", "version", "architecture", "num_threads")}
            | {"library": os.path.basename(str(lib.get("filepath", "")))}
        )
    return out


def numpy_blas_kernel() -> str:
    """The kernel (``architecture``) of the first OpenBLAS loaded, e.g. ``Haswell``; ``?`` if none."""
    for lib in blas_kernels():
        if lib.get("internal_api") == "openblas":
            return str(lib.get("architecture"))
    return "?"


def numpy_avx512_targets() -> list[str]:
    """NumPy's dispatch targets above AVX2 (x86-64-v3) that this CPU runs, e.g. ``X86_V4``;
    naming them in ``NPY_DISABLE_CPU_FEATURES`` makes NumPy take the loops an AVX2 CPU takes."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # another NumPy layout: nothing known to disable
        return []
    return [t for t in __cpu_dispatch__ if __cpu_features__.get(t) and ("AVX512" in t or t == "X86_V4")]


def portable_profile() -> dict[str, str]:
    """Environment that makes every numerical library take its AVX2 code path: OpenBLAS's
    Haswell kernel, NumPy without its AVX-512 loops, torch's AVX2 kernels, numba compiling for
    Haswell. Any x86-64 CPU with AVX2 computes the same bits under it (set it before Python
    starts; the libraries read it when they load). Empty on CPUs without AVX2."""
    if "avx2" not in cpu_flags():
        return {}
    env = {
        "OPENBLAS_CORETYPE": "Haswell",
        "ATEN_CPU_CAPABILITY": "avx2",
        "NUMBA_CPU_NAME": "haswell",
        "MKL_ENABLE_INSTRUCTIONS": "AVX2",
    }
    targets = numpy_avx512_targets()
    if targets:
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(targets)
    return env


def numeric_variants() -> dict[str, dict[str, str]]:
    """{name: environment} of the code paths this CPU can take besides its own: each OpenBLAS
    kernel it runs (SkylakeX where AVX-512 exists, Haswell, Sandybridge), the AVX2 profile
    (:func:`portable_profile`: what an AVX2-only CPU computes) where the CPU has AVX-512, and
    torch's portable ``default`` kernels. A result that changes under one of them would change
    on another machine. Empty on CPUs without AVX2 (not x86-64, or too old to matter)."""
    flags = set(cpu_flags())
    if "avx2" not in flags:
        return {}
    out = {"Haswell": {"OPENBLAS_CORETYPE": "Haswell"}, "Sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"}}
    if "avx512f" in flags:
        out["SkylakeX"] = {"OPENBLAS_CORETYPE": "SkylakeX"}
        out["avx2-profile"] = portable_profile()
    out["torch-default"] = {"ATEN_CPU_CAPABILITY": "default"}
    return out


def environment() -> dict:
    """Versions, CPU and BLAS kernels of this process (computed once per process)."""
    if "env" not in _CACHE:
        versions = {}
        for p in PACKAGES:
            with contextlib.suppress(metadata.PackageNotFoundError):
                versions[p] = metadata.version(p)
        env = {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "versions": versions,
            "cpu": _cpuinfo("model name") or platform.processor() or platform.machine(),
            "cpu_flags": cpu_flags(),
            "blas": blas_kernels(),
            "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
            "numeric_env": {k: os.environ[k] for k in NUMERIC_ENV if k in os.environ},
        }
        try:
            import torch

            env["torch_cpu_capability"] = torch.backends.cpu.get_cpu_capability()
        except Exception:  # torch absent or too old: the record simply lacks it
            pass
        _CACHE["env"] = env
    return _CACHE["env"]


def differences(reference: dict | None, current: dict) -> list[str]:
    """Human-readable lines on how ``current`` differs from ``reference`` (both from
    :func:`environment`); empty when they agree or the reference has no record."""
    if not reference:
        return ["the reference records no environment"]
    lines = []
    for key in ("python", "cpu", "cpu_flags", "OPENBLAS_CORETYPE", "numeric_env", "torch_cpu_capability"):
        if reference.get(key) != current.get(key) and (reference.get(key) or current.get(key)):
            lines.append(f"{key}: reference {reference.get(key)!r}, here {current.get(key)!r}")
    rv, cv = reference.get("versions", {}), current.get("versions", {})
    for p in sorted(set(rv) | set(cv)):
        if rv.get(p) != cv.get(p):
            lines.append(f"{p}: reference {rv.get(p)}, here {cv.get(p)}")
    rk = [(b.get("internal_api"), b.get("architecture"), b.get("version")) for b in reference.get("blas", [])]
    ck = [(b.get("internal_api"), b.get("architecture"), b.get("version")) for b in current.get("blas", [])]
    if rk != ck:
        lines.append(f"BLAS kernels: reference {rk}, here {ck}")
    return lines


def main(argv: list[str] | None = None) -> int:
    """``python -m catpose.bench.run.environment portable``: ``export`` lines of
    :func:`portable_profile` for scripts (``eval "$(...)"``)."""
    import shlex
    import sys

    if (sys.argv[1:] if argv is None else argv) != ["portable"]:
        print("usage: python -m catpose.bench.run.environment portable", file=sys.stderr)
        return 2
    print("\n".join(f"export {k}={shlex.quote(v)}" for k, v in portable_profile().items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
