"""Ours on the embedded mugs (protocol=templates, seed 0) with the mug meshes of another shape
generator module (argv[1], e.g. ``git show 8236609:datasets/shapes.py``) and with today's; prints
the template-chosen error of every view for each solver x rule and whether the meshes are equal."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np

import catpose.datasets.synthetic as synthetic
from catpose.bench.protocols import Templates
from catpose.bench.scoring.metrics import sample_errors
from catpose.methods.ours import OptimiserSettings, Ours, SelectionSettings


def load_generators(path: str):
    spec = importlib.util.spec_from_file_location("old_shapes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.SHAPES


def run(shapes, solver: str, rule: str) -> list[float]:
    saved = synthetic.SHAPES
    synthetic.SHAPES = shapes
    try:
        ds = synthetic.SyntheticDataset(seed=0, categories=["mug"])
        proto = Templates()
        method = Ours(optimiser=OptimiserSettings(solver=solver), selection=SelectionSettings(rule=rule))
        groups: dict[str, list[tuple[float, float]]] = {}
        for sid in proto.sample_ids(ds):
            s = proto.load(ds, sid)
            r = method.register(s.problem)
            e = sample_errors(r.T_template_camera, s.gt.T_template_camera, s.gt.symmetry_axis, s.gt.symmetries)
            groups.setdefault(s.group_id, []).append((r.score, e["err_deg"]))
        return [min(v)[1] for v in groups.values()]
    finally:
        synthetic.SHAPES = saved


def main() -> None:
    old = load_generators(sys.argv[1])
    rng_a, rng_b = np.random.default_rng(0), np.random.default_rng(0)
    a, b = old["mug"](rng_a), synthetic.SHAPES["mug"](rng_b)
    same = a.vertices.shape == b.vertices.shape and np.array_equal(a.vertices, b.vertices)
    print(
        f"mug meshes of the two generators (same seed): bit-identical: {same}; "
        f"max vertex difference {np.abs(a.vertices - b.vertices).max() if a.vertices.shape == b.vertices.shape else 'n/a'}"
    )
    for solver, rule in [("adam", "chamfer"), ("irls", "chamfer"), ("irls", "visibility")]:
        for name, shapes in (("old generator", old), ("today's generator", synthetic.SHAPES)):
            errs = run(shapes, solver, rule)
            print(
                f"{name}, solver={solver}, rule={rule}: mean {np.mean(errs):.2f} deg, views {[round(x, 1) for x in errs]}"
            )


if __name__ == "__main__":
    main()
