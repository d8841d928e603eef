"""Running a script under one of this CPU's numeric code paths
(:func:`catpose.bench.run.environment.numeric_variants`) in a fresh Python, for the tests that
compare bits across OpenBLAS kernels and NumPy dispatch levels."""

from __future__ import annotations

import os
import subprocess
import sys


def last_line(script: str, env_extra: dict[str, str], timeout: int = 600) -> str:
    """The last line ``script`` prints, run by this Python with ``env_extra`` set over the
    environment (whose own OPENBLAS_CORETYPE and NPY_DISABLE_CPU_FEATURES are dropped first);
    the script must succeed."""
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    proc = subprocess.run(
        [sys.executable, "-c", script], env=dict(base, **env_extra), capture_output=True, text=True, timeout=timeout
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout.strip().splitlines()[-1]
