"""The software and hardware a run's numbers came from, and how two such records differ.

Last-bit floating-point differences between machines come from library versions and from the
BLAS kernel chosen at run time for the CPU (OpenBLAS: SkylakeX, Haswell, Zen, Sandybridge...;
torch's own CPU capability). Every ``run.json`` and every regression reference records them, so
that a result that moved can be traced to the code or to the machine.
"""

from __future__ import annotations

import os
import platform
from importlib import metadata
from typing import Any

PACKAGES = ("numpy", "scipy", "open3d-cpu", "open3d", "torch", "trimesh", "hydra-core")
_CACHE: dict[str, Any] = {}


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``; ``platform.processor()`` elsewhere)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def cpu_flags() -> list[str]:
    """The vector extensions the CPU reports that decide BLAS kernels (avx, avx2, avx512f, ...)."""
    wanted = {"sse4_2", "avx", "avx2", "fma", "avx512f", "avx512_bf16", "amx_tile", "asimd", "sve"}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith(("flags", "Features")):
                    return sorted(wanted & set(line.split(":", 1)[1].split()))
    except OSError:
        pass
    return []


def blas_kernels() -> list[dict]:
    """The BLAS libraries loaded in this process with the kernel each chose (threadpoolctl)."""
    import numpy  # noqa: F401  (loads OpenBLAS so that threadpoolctl sees it)
    from threadpoolctl import threadpool_info

    out = []
    for lib in threadpool_info():
        if lib.get("user_api") != "blas":
            continue
        out.append({k: lib.get(k) for k in ("internal_api", "version", "architecture", "num_threads")}
                   | {"library": os.path.basename(str(lib.get("filepath", "")))})
    return out


def numpy_blas_kernel() -> str:
    """The kernel (``architecture``) of the first OpenBLAS loaded, e.g. ``Haswell``; ``?`` if none."""
    for lib in blas_kernels():
        if lib.get("internal_api") == "openblas":
            return str(lib.get("architecture"))
    return "?"


def environment() -> dict:
    """Versions, CPU and BLAS kernels of this process (computed once per process)."""
    if "env" not in _CACHE:
        versions = {p: v for p in PACKAGES if (v := _version(p))}
        env = {"python": platform.python_version(), "platform": platform.platform(), "versions": versions,
               "cpu": cpu_model(), "cpu_flags": cpu_flags(), "blas": blas_kernels(),
               "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE")}
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
    for key in ("python", "cpu", "cpu_flags", "OPENBLAS_CORETYPE", "torch_cpu_capability"):
        if reference.get(key) != current.get(key):
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
