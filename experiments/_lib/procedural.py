"""Procedural chairs or airplanes drawn part by part from a seed, written as a
``modelnet40_resampled`` root: a development set of any size in the category frame of the shared
ModelNet40 shapes (which are few: 5 chairs, 18 airplanes, and report results), for the studies
category_choice and selection_breadth.

The generators are the sibling scripts ``procedural_chairs.py`` and ``procedural_airplanes.py``.
Shape ``i`` of a set is drawn by ``numpy.random.default_rng(shape_seed)`` after shapes ``0..i-1``
and sampled to 10,000 points with face normals (area-uniform, seed ``shape_seed * 100003 + i``),
written ``%.6f`` in PointNet++'s resampled layout (``<root>/<category>/<category>_<8000 + i>.txt``,
lines ``x,y,z,nx,ny,nz``, y up); so a set is fixed by its category, count and seed, and, in the last
printed digit of a few points, by the BLAS kernel (:func:`blas_kernel`; the portable numeric profile
gives every AVX2 CPU the same set).

A root also has the split files (every id in ``modelnet40_train.txt``, ``modelnet40_test.txt``
empty), ``alignment_<category>.csv`` (the identity for every drawn shape, its note
``procedural[ <kind>]: built in the category frame``) and ``spec.json`` (what made it). Shapes of
another root, e.g. the shared resampled chairs, can be linked in as templates (``--template-root``,
``--template-ids``), with their rows of a verified alignment table (``--template-alignment``) or,
without one, the identity. A root appears whole or not at all (:func:`catpose.atomic.building_dir`)::

    python experiments/_lib/procedural.py OUT_ROOT --category chair --count 40 --shape-seed 0 \\
        [--template-root SHARED/modelnet40_normal_resampled --template-ids chair_0391,chair_0624 \\
         [--template-alignment results/alignment/modelnet40_resampled_chair.csv]]

writes the root into ``OUT_ROOT`` (again: nothing to do), for ``dataset=modelnet40_resampled
dataset.root=OUT_ROOT dataset.alignment_table=OUT_ROOT/alignment_<category>.csv``.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import sys
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from catpose.errors import CatposeError, ConfigError, DatasetError

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the generators, sibling scripts

#: bumped whenever the written files change for the same spec
GENERATOR_VERSION = "1"
#: the first drawn shape's number (``chair_8000``): above every ModelNet40 id of both categories
FIRST_ID = 8000
POINTS = 10000
CATEGORIES = ("chair", "airplane")
HEADER = "category,instance_id,r00,r01,r02,r10,r11,r12,r20,r21,r22,yaw_deg,flip,chamfer,confidence,verified,note\n"
IDENTITY = "1,0,0,0,1,0,0,0,1,0,false,,,true"


@dataclass(frozen=True)
class ProceduralSpec:
    """What a procedural root holds: ``count`` shapes of ``category`` drawn from ``shape_seed``,
    and the templates ``template_ids`` linked from ``template_root`` (a resampled root; resolved
    path) with their rows of ``template_alignment`` (None: identity rows)."""

    category: str
    count: int
    shape_seed: int
    template_ids: tuple[str, ...] = ()
    template_root: str | None = None
    template_alignment: str | None = None

    def __post_init__(self) -> None:
        if self.category not in CATEGORIES:
            raise ConfigError(f"--category {self.category!r} is not one of {', '.join(CATEGORIES)}")
        if int(self.count) < 1:
            raise ConfigError(f"--count {self.count}: draw at least 1 shape")
        if self.template_ids and self.template_root is None:
            raise ConfigError(
                f"templates {', '.join(self.template_ids)} are not drawn shapes; set --template-root "
                "to the resampled root that holds them"
            )

    def record(self) -> dict:
        """The spec as ``spec.json`` stores it, with the generator version, the template table's
        content hash (its rows are copied into the root) and the BLAS kernel (:func:`blas_kernel`)."""
        table = None
        if self.template_alignment is not None:
            table = hashlib.blake2b(Path(self.template_alignment).read_bytes(), digest_size=8).hexdigest()
        return {
            "version": GENERATOR_VERSION,
            **asdict(self),
            "template_ids": list(self.template_ids),
            "table": table,
            "blas": blas_kernel(),
        }


def blas_kernel() -> str:
    """The BLAS libraries' kernels this process uses (threadpoolctl), e.g. ``openblas:Haswell``.
    The generators place their parts with trimesh's matrix products, whose last bits depend on the
    kernel: a few points' last printed digit and the sign of a zero normal component differ between
    OpenBLAS's Haswell and Sandybridge kernels. So a set is one kernel's bits, and the kernel is part
    of its spec; under the portable numeric profile (``python -m catpose.bench.run.environment
    portable``, Haswell) every AVX2 CPU writes the same set."""
    import numpy  # noqa: F401  (loads the BLAS that threadpoolctl reports)
    from threadpoolctl import threadpool_info

    found = sorted(
        {f"{i.get('internal_api')}:{i.get('architecture')}" for i in threadpool_info() if i.get("user_api") == "blas"}
    )
    return ",".join(found) or "unknown"


def shape_ids(category: str, count: int) -> list[str]:
    """The drawn shapes' instance ids: ``<category>_8000`` ... in drawing order."""
    return [f"{category}_{FIRST_ID + i}" for i in range(count)]


def resampled(mesh, seed: int) -> np.ndarray:
    """(10000, 6) points on ``mesh`` (area-uniform, ``seed``) and their faces' normals."""
    import trimesh

    pts, face = trimesh.sample.sample_surface(mesh, POINTS, seed=seed)
    return np.hstack([pts, mesh.face_normals[face]])


def draw(category: str, rng: np.random.Generator):
    """The next shape of ``category`` from ``rng`` (a trimesh mesh; airplanes carry their kind in
    ``metadata["kind"]``)."""
    if category == "chair":
        from procedural_chairs import chair

        return chair(rng)
    from procedural_airplanes import airplane

    return airplane(rng)


def template_rows(alignment_csv: Path, ids: Sequence[str]) -> list[str]:
    """The rows of ``ids`` in the alignment table ``alignment_csv``, as CSV lines in ``HEADER``'s
    columns (a value with a comma quoted)."""
    with open(alignment_csv, newline="") as f:
        rows = {r["instance_id"]: r for r in csv.DictReader(f)}
    missing = [i for i in ids if i not in rows]
    if missing:
        raise DatasetError(f"{alignment_csv} has no row for {', '.join(missing)}; give the table of --template-root")
    out = []
    for i in ids:
        vals = [rows[i][k] for k in HEADER.strip().split(",")]
        out.append(",".join(f'"{v}"' if "," in v else v for v in vals) + "\n")
    return out


def write_root(root: Path, spec: ProceduralSpec) -> None:
    """Write ``spec``'s shapes, links, split files and alignment table into the existing folder
    ``root`` (see the module docstring); :func:`build_root` is the atomic caller."""
    folder = root / spec.category
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(spec.shape_seed)
    names = shape_ids(spec.category, spec.count)
    rows = []
    for i, name in enumerate(names):
        mesh = draw(spec.category, rng)
        np.savetxt(folder / f"{name}.txt", resampled(mesh, spec.shape_seed * 100003 + i), delimiter=",", fmt="%.6f")
        kind = mesh.metadata.get("kind")
        rows.append(
            f"{spec.category},{name},{IDENTITY},procedural{f' {kind}' if kind else ''}: built in the category frame\n"
        )
    for name in spec.template_ids:
        source = Path(spec.template_root) / spec.category / f"{name}.txt"
        if not source.is_file():
            raise DatasetError(f"template {source} does not exist; check --template-root and --template-ids")
        (folder / f"{name}.txt").symlink_to(source.resolve())
    if spec.template_alignment is not None:
        rows += template_rows(Path(spec.template_alignment), spec.template_ids)
    else:
        rows += [f"{spec.category},{n},{IDENTITY},shared template (results/alignment/)\n" for n in spec.template_ids]
    (root / "modelnet40_train.txt").write_text("".join(f"{n}\n" for n in sorted([*names, *spec.template_ids])))
    (root / "modelnet40_test.txt").write_text("")
    (root / f"alignment_{spec.category}.csv").write_text(HEADER + "".join(rows))
    (root / "spec.json").write_text(json.dumps(spec.record(), indent=1) + "\n")


def build_root(root: str | Path, spec: ProceduralSpec) -> Path:
    """``root`` holding ``spec``'s set: written whole (:func:`catpose.atomic.building_dir`) where
    it is missing or an empty folder, kept where ``spec.json`` says it holds ``spec``; any other
    existing folder is refused (nothing is written into what this did not create)."""
    from catpose.atomic import building_dir

    root = Path(root)
    if root.exists() and not (root.is_dir() and not any(root.iterdir())):
        try:
            found = json.loads((root / "spec.json").read_text())
        except (OSError, ValueError):
            found = None
        if found == spec.record():
            return root
        raise DatasetError(
            f"{root} exists and does not hold this procedural set (its spec.json differs or is missing); "
            "remove it or choose another folder"
        )
    with building_dir(root) as tmp:
        write_root(tmp, spec)
    return root


def kinds(alignment_csv: str | Path) -> dict[str, str]:
    """instance id -> kind of every drawn airplane of a root's alignment table (its note
    ``procedural <kind>: ...``; chairs have none)."""
    with open(alignment_csv, newline="") as f:
        return {
            r["instance_id"]: r["note"].split(":")[0].removeprefix("procedural ").strip()
            for r in csv.DictReader(f)
            if r["note"].startswith("procedural ")
        }


def main(argv: list[str] | None = None) -> int:
    """``python experiments/_lib/procedural.py OUT_ROOT ...``: write a procedural root (see the
    module docstring); a bad argument is one line and exit status 2."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out_root")
    ap.add_argument("--category", choices=CATEGORIES, required=True)
    ap.add_argument("--count", type=int, default=40, help="shapes drawn")
    ap.add_argument("--shape-seed", type=int, default=0, help="fixes every shape")
    ap.add_argument("--template-root", help="a modelnet40_normal_resampled folder holding the linked templates")
    ap.add_argument("--template-ids", default="", help="','-separated ids of --template-root linked in as templates")
    ap.add_argument("--template-alignment", help="its alignment table (default: identity rows for the templates)")
    args = ap.parse_args(argv)
    ids = tuple(i for i in args.template_ids.split(",") if i)
    try:
        spec = ProceduralSpec(
            category=args.category,
            count=args.count,
            shape_seed=args.shape_seed,
            template_ids=ids,
            template_root=str(Path(args.template_root).resolve()) if args.template_root and ids else None,
            template_alignment=str(Path(args.template_alignment).resolve())
            if args.template_alignment and ids
            else None,
        )
        root = build_root(args.out_root, spec)
    except CatposeError as e:
        print(f"experiments/_lib/procedural.py: error: {e}", file=sys.stderr)
        return 2
    print(f"{root}: {spec.count} procedural {spec.category}s (seed {spec.shape_seed}), {len(ids)} linked templates")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
