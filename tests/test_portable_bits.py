"""Samples are the same bits on every x86-64 CPU: their problems and ground truth do not depend on
which code paths the numerical libraries choose for the machine (OpenBLAS's kernel, NumPy's
AVX-512 or AVX2 loops, Embree's instruction set).

Two checks. The first runs the sample-making code under every code path this CPU can take
(:func:`catpose.bench.run.environment.numeric_variants`: SkylakeX, Haswell and Sandybridge kernels,
NumPy without AVX-512) and compares hashes of everything a method or the scorer reads. The second
reads the source: no BLAS product, 1-D ``np.linalg.norm`` or CPU-dispatched NumPy transcendental
is left under ``datasets/`` and ``src/catpose/`` (Embree's path cannot be switched from here;
:meth:`catpose.raycast.RayCaster.cast` recomputes every hit in float64, tested in
``test_render.py``).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

from catpose.bench.run.environment import numeric_variants

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _code_paths import last_line  # noqa: E402

REPO = Path(__file__).resolve().parents[1]

SCRIPT = r"""
import hashlib, json, os
import numpy as np
from catpose.bench.run.environment import numpy_blas_kernel
from catpose.bench.protocols.absolute import GtModel
from catpose.raycast import RayCaster
from catpose.datasets.shapes import make_shape
from catpose.datasets.synthetic import SyntheticDataset
from catpose.datasets.views import ImageOptions, ViewOptions

def digest(*arrays):
    h = hashlib.sha1()
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()

out = {"kernel": numpy_blas_kernel()}
proto = GtModel()
plain = SyntheticDataset(seed=3, instances_per_category=1, views_per_instance=1, view=ViewOptions(max_points=500),
                         template_points=500, ground_normal_noise_deg=2.0)
for sid in proto.sample_ids(plain):
    s = proto.load(plain, sid)
    out[sid] = digest(s.problem.points_camera, s.problem.normals_camera, s.problem.ground_normal_camera,
                      s.problem.template.points, s.problem.template.normals, s.gt.T_template_camera)
sensor = SyntheticDataset(seed=5, categories=["mug", "chair"], instances_per_category=1, views_per_instance=1,
                          view=ViewOptions(max_points=500), template_points=500, sensor="kinect",
                          image=ImageOptions(width=320, height=240, fx=290.0, fy=290.0))
for sid in proto.sample_ids(sensor):
    s = proto.load(sensor, sid)
    out["kinect/" + sid] = digest(s.problem.points_camera, s.problem.normals_camera, s.problem.ground_normal_camera,
                                  s.gt.T_template_camera)
for t in plain.category_templates("airplane"):
    out["template/" + t.template_id] = digest(t.points, t.normals)
mesh = make_shape("car", np.random.default_rng(0))
rng = np.random.default_rng(1)
origins = rng.normal(size=(20000, 3)) * 0.1 + np.array([0.0, 0.0, -3.0])
out["rays"] = digest(RayCaster(mesh.vertices, mesh.faces).cast(origins, -origins + rng.normal(size=(20000, 3)) * 0.3))
print(json.dumps(out))
"""


def _digests(env_extra: dict[str, str]) -> dict[str, str]:
    import json

    return json.loads(last_line(SCRIPT, env_extra))


@pytest.mark.slow  # > 5 s: make test-slow
def test_samples_are_bit_identical_under_every_code_path_of_this_cpu():
    """8 categories, 2 sensor-model views (table, noise, ground-plane fit), category templates and
    20,000 cast rays hash the same under each OpenBLAS kernel and NumPy dispatch level."""
    variants = {k: v for k, v in numeric_variants().items() if k != "torch-default"}  # torch makes no sample
    if not variants:
        pytest.skip("needs an x86-64 CPU with AVX2 to run other OpenBLAS kernels")
    first_name, first_env = next(iter(variants.items()))
    first = _digests(first_env)
    assert len([k for k in first if "/" in k and not k.startswith(("kinect/", "template/"))]) == 8
    kernel = first_env.get("OPENBLAS_CORETYPE")
    assert first["kernel"] == kernel, f"OpenBLAS did not take OPENBLAS_CORETYPE={kernel}: {first['kernel']}"
    for name, env in list(variants.items())[1:]:
        other = _digests(env)
        if "OPENBLAS_CORETYPE" in env:
            assert other["kernel"] == env["OPENBLAS_CORETYPE"], f"OpenBLAS ignored {env}"
        diff = sorted(k for k in first if k != "kernel" and first[k] != other.get(k))
        assert not diff, f"samples differ between {first_name} and {name}: {diff}"


# ------------------------------------------------------------------------------ the source rule

#: NumPy ufuncs whose float64 loops are dispatched per CPU and round differently on AVX-512
#: (measured with NPY_DISABLE_CPU_FEATURES); use catpose.libm instead.
DISPATCHED_UFUNCS = {
    "exp",
    "exp2",
    "expm1",
    "log",
    "log2",
    "log10",
    "log1p",
    "arccos",
    "arcsin",
    "arctan",
    "arctan2",
    "tan",
    "power",
    "float_power",
    "cbrt",
    "sinh",
    "cosh",
    "tanh",
    "arcsinh",
    "arccosh",
    "arctanh",
}
BLAS_CALLS = {"dot", "matmul", "inner", "vdot", "tensordot"}


def portability_violations(source: str) -> list[tuple[int, str]]:
    """(line, what) for each construct whose result depends on the CPU's BLAS kernel or NumPy's
    dispatch: ``@``, ``np.dot``-like calls and ``.dot``, ``np.linalg.norm`` without ``axis``,
    dispatched transcendental ufuncs, and ``**`` with an exponent other than a literal 2, 3, 0.5
    or 1 (NumPy routes those to ``power``)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
            out.append((node.lineno, f"@ in {ast.unparse(node)}"))
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            if not (isinstance(node.right, ast.Constant) and node.right.value in (1, 2, 3, 0.5)):
                out.append((node.lineno, f"** in {ast.unparse(node)} (use catpose.libm.power)"))
        elif isinstance(node, ast.Call):
            name = ast.unparse(node.func)
            last = name.rsplit(".", 1)[-1]
            if name in ("np.linalg.norm", "numpy.linalg.norm") and not any(k.arg == "axis" for k in node.keywords):
                out.append((node.lineno, f"1-D {ast.unparse(node)} (use catpose.geometry.norm3)"))
            elif name.startswith(("np.", "numpy.")) and last in DISPATCHED_UFUNCS:
                out.append((node.lineno, f"{name} (use catpose.libm.{last})"))
            elif (name.startswith(("np.", "numpy.")) and last in BLAS_CALLS) or (
                isinstance(node.func, ast.Attribute) and node.func.attr == "dot"
            ):
                out.append((node.lineno, f"BLAS {name}"))
    return sorted(out)


def test_the_rule_finds_each_kind_of_violation():
    src = (
        "import numpy as np\n"
        "a = R @ v\n"
        "b = np.linalg.norm(v)\n"
        "c = np.linalg.norm(V, axis=1)\n"
        "d = np.arccos(x)\n"
        "e = np.cos(x)\n"
        "f = x ** 2 + x ** k\n"
        "g = np.dot(a, b) + a.dot(b)\n"
    )
    lines = [line for line, _ in portability_violations(src)]
    assert lines == [2, 3, 5, 7, 8, 8]


@pytest.mark.parametrize("folder", ["datasets", "src/catpose", "bench/scoring/metrics.py"])
def test_no_cpu_dependent_arithmetic_in_sample_code(folder: str):
    """Nor in the scorer's errors, which every table recomputes from the stored poses."""
    root = REPO / folder
    bad = [
        f"{p.relative_to(REPO)}:{line}: {what}"
        for p in ([root] if root.is_file() else sorted(root.rglob("*.py")))
        for line, what in portability_violations(p.read_text())
    ]
    assert not bad, "CPU-dependent arithmetic where samples are made:\n" + "\n".join(bad)


def test_golden_inputs_are_what_this_machine_renders():
    """The committed golden inputs of ``bench regress`` (rendered on one machine) are bit for bit
    what this machine renders from the suite's settings (float32 as stored): whatever CPU made
    them, the problems are the same."""
    import numpy as np

    from catpose.bench.regress import run_suites
    from catpose.bench.regress.golden import _f32

    _, suites = run_suites.load_config()
    suite = suites["synthetic"]
    golden = np.load(suite.inputs)
    live = run_suites.Suite(**{**suite.__dict__, "inputs": None})
    dataset, protocol, ids = run_suites.suite_samples(live)
    assert len(ids) == 24
    for i, sid in enumerate(ids):
        s = protocol.load(dataset, sid)
        for key, a in (
            ("p", s.problem.points_camera),
            ("n", s.problem.normals_camera),
            ("g", s.problem.ground_normal_camera),
        ):
            assert np.array_equal(golden[f"{key}{i}"], _f32(a)), f"{sid}: {key} differs from the golden inputs"
        assert np.array_equal(golden[f"T{i}"], s.gt.T_template_camera), sid
