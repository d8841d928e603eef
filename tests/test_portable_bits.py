"""The embedded set is the same bits under every BLAS kernel: its problems and ground truth do
not depend on which CPU made them (OpenBLAS picks a kernel per CPU at run time)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from catpose.bench.environment import cpu_flags

SCRIPT = r"""
import hashlib, sys
import numpy as np
from catpose.bench.environment import numpy_blas_kernel
from catpose.bench.protocols import GtModel
from catpose.datasets.synthetic import SyntheticDataset

ds = SyntheticDataset(seed=3, instances_per_category=1, views_per_instance=1, max_points=500, template_points=500,
                      ground_normal_noise_deg=2.0)
proto = GtModel()
print("kernel", numpy_blas_kernel())
for sid in proto.sample_ids(ds):
    s = proto.load(ds, sid)
    h = hashlib.sha1()
    for a in (s.problem.points_camera, s.problem.normals_camera, s.problem.ground_normal_camera,
              s.problem.template.points, s.problem.template.normals, s.gt.T_template_camera):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    print(sid, h.hexdigest())
"""


def kernels_here() -> list[str]:
    """OpenBLAS kernels this CPU can run: Haswell and Sandybridge on any AVX2 machine, SkylakeX
    where AVX-512 is present."""
    flags = set(cpu_flags())
    if "avx2" not in flags:
        return []
    return ["Haswell", "Sandybridge"] + (["SkylakeX"] if "avx512f" in flags else [])


def _hashes(kernel: str) -> list[str]:
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=dict(os.environ, OPENBLAS_CORETYPE=kernel),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == f"kernel {kernel}", f"OpenBLAS did not take OPENBLAS_CORETYPE={kernel}: {lines[0]}"
    return lines[1:]


def test_synthetic_samples_are_bit_identical_across_blas_kernels():
    kernels = kernels_here()
    if len(kernels) < 2:
        pytest.skip("needs an x86-64 CPU with AVX2 to run two OpenBLAS kernels")
    first = _hashes(kernels[0])
    assert len(first) == 8
    for k in kernels[1:]:
        other = _hashes(k)
        diff = [a.split()[0] for a, b in zip(first, other) if a != b]
        assert not diff, f"samples differ between {kernels[0]} and {k}: {diff}"
