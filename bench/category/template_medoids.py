"""Choose K category templates by K-medoids over a pairwise F-score distance (paper, Sec. IV-B).

The training instances of a category are compared in their canonical frames (aligned, unit
bounding sphere): the distance of two shapes is ``1 - F-score@tau`` of their complete point
clouds (Tatarchenko et al., "What do single-view 3D reconstruction networks learn?", CVPR 2019):

    precision = |{p in P : d(p, Q) < tau}| / |P|,  recall = |{q in Q : d(q, P) < tau}| / |Q|
    F = 2 * precision * recall / (precision + recall)

PAM (:func:`pam`, BUILD then best swaps, in NumPy) picks the K medoids; scikit-learn's
silhouette score over the same precomputed distances is reported for every K (``--k auto`` takes
the best). The instances must be in one frame: a dataset whose frames are not declared consistent
(raw ModelNet40) is refused unless it has an alignment table (``results/alignment/``)::

    bench templates dataset=modelnet40_resampled dataset.root=/data/modelnet40_normal_resampled \
        dataset.alignment_table=results/alignment/modelnet40_resampled_chair.csv \
        --category chair --k 5 --out my_templates/templates/modelnet40_resampled_chair.yaml

The YAML holds only ``{category: [instance ids]}`` (the shape of a dataset's ``templates``
option) under the Hydra header ``# @package dataset.templates``, with the settings, silhouette
scores and clusters as comments, so a file ``<dir>/templates/<name>.yaml`` is a config group that
merges into the dataset's templates::

    bench run method=ours dataset=modelnet40 protocol=templates +templates=<name> \
        hydra.searchpath=[file://<dir>]
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from catpose.datasets.views import subsample
from catpose.errors import ConfigError, DatasetError


def instance_ids(dataset: Any, category: str, split: str | None = None) -> list[str]:
    """Instance ids of ``category`` in ``split`` (None: the dataset's own split), no duplicates: the
    instances the category tools work on (``bench templates``, ``experiments/alignment/align.py``).

    Datasets say it in three ways, tried in this order: ``dataset.instance_ids(category, split)``
    (ModelNet40 from OFF files); ``dataset.split_ids(split)`` with
    ``dataset.category_of_instance(id)`` (ModelNet40 resampled: one split file for every category);
    otherwise the instances observed in ``dataset.observation_ids()``, in order, each read from its
    observation (``Observation.instance_id``), for datasets without splits (the synthetic set, BOP
    scenes), where ``split`` does not apply.
    """
    if hasattr(dataset, "instance_ids"):
        return list(dataset.instance_ids(category, split))
    if hasattr(dataset, "split_ids"):
        return [i for i in dataset.split_ids(split) if dataset.category_of_instance(i) == category]
    ids: dict[str, None] = {}
    for obs_id in dataset.observation_ids():
        if dataset.category_of(obs_id) == category:
            ids.setdefault(str(dataset.observation(obs_id).instance_id))
    return list(ids)


def fscore(P: np.ndarray, Q: np.ndarray, tau: float) -> float:
    """F-score at distance ``tau`` between point clouds ``P`` (N, 3) and ``Q`` (M, 3), same frame and unit."""
    from scipy.spatial import cKDTree

    d_pq = cKDTree(Q).query(P, k=1)[0]
    d_qp = cKDTree(P).query(Q, k=1)[0]
    precision, recall = float((d_pq < tau).mean()), float((d_qp < tau).mean())
    return 0.0 if precision + recall == 0 else 2 * precision * recall / (precision + recall)


def fscore_distances(clouds: Sequence[np.ndarray], tau: float) -> np.ndarray:
    """(N, N) symmetric matrix of ``1 - F-score@tau`` between N clouds (zero diagonal)."""
    n = len(clouds)
    D = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            D[i, j] = D[j, i] = 1.0 - fscore(clouds[i], clouds[j], tau)
    return D


def pam(D: np.ndarray, k: int, max_iter: int = 100) -> np.ndarray:
    """K medoid indices (K,) of the (N, N) distance matrix ``D`` by PAM (Kaufman and Rousseeuw,
    "Partitioning Around Medoids", 1990), in NumPy. BUILD adds, K times, the point that lowers the
    loss ``sum_i min_m D[i, m]`` most (ties: the lowest index); SWAP then makes the exchange of a
    medoid for a point that lowers it most, all K x N of them at once, until none lowers it by more
    than a relative 1e-12 (rounding never swaps between equal losses). Deterministic."""
    n = len(D)
    medoids = [int(np.argmin(D.sum(axis=0)))]
    nearest = D[:, medoids[0]].copy()
    for _ in range(1, k):
        gain = np.minimum(D - nearest[:, None], 0.0).sum(axis=0)  # (N,) loss change per candidate
        gain[medoids] = np.inf
        medoids.append(int(np.argmin(gain)))
        nearest = np.minimum(nearest, D[:, medoids[-1]])
    medoids, loss = np.array(medoids), nearest.sum()
    for _ in range(max_iter if 1 < k < n else 0):
        order = np.argsort(D[:, medoids], axis=1, kind="stable")
        dn, ds = np.take_along_axis(D[:, medoids], order[:, :2], axis=1).T  # nearest, second nearest
        # each point's distance to the medoids left without slot b (N, K), then with point j added
        rest = np.where(order[:, :1] == np.arange(k), ds[:, None], dn[:, None])
        after = np.minimum(D[:, :, None], rest[:, None, :]).sum(axis=0)  # (N points j, K slots b)
        after[medoids] = np.inf
        j, b = np.unravel_index(np.argmin(after), after.shape)
        if after[j, b] >= loss - 1e-12 * max(loss, 1.0):
            break
        medoids[b], loss = j, after[j, b]
    return medoids


def select_medoids(D: np.ndarray, k: int) -> tuple[list[int], np.ndarray]:
    """K medoids of a distance matrix (:func:`pam`): (medoid indices sorted by cluster size,
    largest first, ties by index; (N,) labels indexing that medoid list)."""
    n = len(D)
    if not 1 <= k <= n:
        raise ConfigError(f"--k {k} must be between 1 and the number of instances ({n})")
    medoids = pam(np.asarray(D, float), k)
    labels = np.argmin(D[:, medoids], axis=1)
    sizes = np.bincount(labels, minlength=len(medoids))
    order = sorted(range(len(medoids)), key=lambda c: (-sizes[c], int(medoids[c])))
    remap = np.empty(len(order), int)
    remap[order] = np.arange(len(order))
    return [int(medoids[c]) for c in order], remap[labels]


def silhouette_by_k(D: np.ndarray, ks: Sequence[int]) -> dict[int, float]:
    """Mean silhouette (scikit-learn, ``metric="precomputed"``) of the K-medoids clustering of the
    (N, N) distance matrix ``D`` for each K in ``ks`` with 2 <= K <= N - 1 (higher is better)."""
    from sklearn.metrics import silhouette_score

    n = len(D)
    return {
        int(k): float(silhouette_score(D, select_medoids(D, int(k))[1], metric="precomputed"))
        for k in ks
        if 2 <= int(k) <= n - 1
    }


def choose_templates(
    clouds: dict[str, np.ndarray], k: int | str, tau: float = 0.05, n_points: int = 2048, seed: int = 0
) -> dict:
    """Pick ``k`` template ids among ``clouds`` (instance id -> (N, 3) complete cloud, canonical frame).

    ``k="auto"`` takes the K (2..N-1) with the highest silhouette score.

    Returns ``{"templates": [ids, largest cluster first], "clusters": {id: [members]},
    "mean_distance": float, "silhouette": {K: score}, "distances": (N, N) array, "ids": [ids]}``
    (``mean_distance``: mean distance of each instance to its medoid).
    """
    ids = list(clouds)
    pts = [subsample(n_points, np.random.default_rng(seed), np.asarray(clouds[i], float))[0] for i in ids]
    D = fscore_distances(pts, tau)
    silhouette = silhouette_by_k(D, range(2, len(ids)))
    if k == "auto":
        if not silhouette:
            raise ConfigError(f"--k auto needs at least 3 instances; there are {len(ids)}")
        k = max(silhouette, key=lambda kk: (silhouette[kk], -kk))
    medoids, labels = select_medoids(D, int(k))
    clusters = {ids[m]: [ids[j] for j in np.flatnonzero(labels == c)] for c, m in enumerate(medoids)}
    mean_d = float(np.mean([D[j, medoids[labels[j]]] for j in range(len(ids))]))
    return {
        "templates": [ids[m] for m in medoids],
        "clusters": clusters,
        "mean_distance": mean_d,
        "silhouette": silhouette,
        "distances": D,
        "ids": ids,
    }


def write_templates_yaml(path: str | Path, category: str, result: dict, settings: dict) -> Path:
    """Write (or update) ``{category: [ids]}`` in ``path``; settings and clusters go in comments.

    The file holds only ``category -> ids`` mappings, the shape of a dataset's ``templates``
    option, so it can be used as that option as it is; other categories already in the file
    are kept.
    """
    import yaml

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = read_templates_yaml(path) if path.is_file() else {}
    doc[category] = list(result["templates"])
    lines = [
        HEADER,
        "# Category templates chosen by `bench templates`: K-medoids (PAM) over 1 - F-score@tau",
        f"# between complete canonical clouds. Last run ({category}): "
        + ", ".join(f"{k}={v}" for k, v in settings.items()),
        f"# mean distance to medoid {result['mean_distance']:.4f}; silhouette by K: "
        + (", ".join(f"{k}: {v:.3f}" for k, v in result.get("silhouette", {}).items()) or "n/a"),
        "# clusters (medoid: members):",
    ]
    lines += [f"#   {m}: {', '.join(members)}" for m, members in result["clusters"].items()]
    from catpose import atomic

    atomic.write_text(path, "\n".join(lines) + "\n" + yaml.safe_dump(doc, sort_keys=True))
    return path


HEADER = "# @package dataset.templates"


def read_templates_yaml(path: str | Path) -> dict[str, list[str]]:
    """A templates file (what :func:`write_templates_yaml` writes): ``{category: [instance ids]}``.
    Anything else (a file that is not YAML, another config whose values are not lists of ids) is
    refused in one line: ``bench templates`` updates templates files only."""
    import yaml

    path = Path(path)
    fix = "pass another --out (bench templates updates templates files only: {category: [ids]})"
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path} cannot be read as a templates file ({type(e).__name__}); {fix}") from None
    try:
        doc = yaml.safe_load(text) or {}
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        raise ConfigError(
            f"{path}{where} is not valid YAML ({getattr(e, 'problem', None) or type(e).__name__}); {fix}"
        ) from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{path} is not a category -> template ids mapping; {fix}")
    for k, v in doc.items():
        if not isinstance(v, list) or not v or not all(isinstance(i, (str, int)) for i in v):
            raise ConfigError(f"{path}: {k!r} is not a category with a list of template ids ({v!r:.40}); {fix}")
    return {str(k): [str(i) for i in v] for k, v in doc.items()}


def check_options(args) -> None:
    """``--tau`` a distance > 0 (object-normalised unit), ``--points`` >= 64, ``--out`` a ``.yaml``."""
    import math

    if not (math.isfinite(args.tau) and args.tau > 0):
        raise ConfigError(f"--tau {args.tau:g} must be a distance > 0 (object-normalised unit, e.g. 0.05)")
    if args.points < 64:
        raise ConfigError(f"--points {args.points}: pass at least 64 points per cloud for the F-score (default 2048)")
    if Path(args.out).suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(f"--out {args.out}: a templates file is a Hydra config: end its name in .yaml")


def main(argv: list[str] | None = None) -> int:
    """``bench templates dataset=NAME [dataset.key=value ...] --category C --k K [--tau T] --out FILE``."""
    ap = argparse.ArgumentParser(
        prog="bench templates", description="Choose K category templates by K-medoids over F-score distance."
    )
    ap.add_argument("overrides", nargs="*", help="Hydra overrides: dataset=NAME dataset.root=... seed=...")
    ap.add_argument("--category", required=True)
    ap.add_argument("--k", default="5", help="number of templates, or 'auto' (best silhouette)")
    ap.add_argument("--tau", type=float, default=0.05, help="F-score distance threshold (object-normalised unit)")
    ap.add_argument(
        "--split",
        default="train",
        help="which instances to cluster (datasets with splits; template_medoids.instance_ids)",
    )
    ap.add_argument("--instances", default=None, help="comma-separated instance ids (default: the split's)")
    ap.add_argument("--points", type=int, default=2048, help="points per cloud")
    ap.add_argument("--seed", type=int, default=0)
    from catpose.bench.run.overwrite import Output, add_output_options

    add_output_options(
        ap,
        "YAML to write (e.g. <dir>/templates/<dataset>_<category>.yaml)",
        force_help="update an existing --out (a file of bench templates: its other categories stay)",
    )
    args = ap.parse_args(argv)
    check_options(args)
    out = Output(args.out, "file", (), args.force, example="templates.yaml")  # before any work
    if Path(args.out).is_file():
        read_templates_yaml(args.out)  # its own kind of file only, refused before the distances are computed
    if args.k != "auto" and not args.k.isdigit():
        raise ConfigError(f"--k {args.k!r} is not a positive integer or 'auto'")
    k = args.k if args.k == "auto" else int(args.k)
    from catpose.bench.protocols.absolute import require_consistent_frames
    from catpose.bench.run.config import compose, compose_and_build

    overrides = list(args.overrides)
    if (
        not any(o.lstrip("+~").startswith("dataset.categories=") for o in overrides)
        and "alignment_table" in compose(overrides).dataset
    ):  # ModelNet40: the category at hand, whose table
        overrides.append(f"dataset.categories=[{args.category}]")  # need not cover the others
    _, ((name, dataset),) = compose_and_build(overrides, ("dataset",))  # one-line errors (missing root, ...)
    require_consistent_frames(dataset, "bench templates")
    known = instance_ids(dataset, args.category, args.split)
    ids = args.instances.split(",") if args.instances else known
    unknown = [i for i in ids if i not in known]
    if unknown or not known:
        raise DatasetError(
            f"--category {args.category!r} has no {args.split} instance{' ' + ', '.join(unknown[:3]) if unknown else 's'}"
            f" in dataset {name} ({'its instances: ' + ', '.join(known[:3]) + ', ...' if known else 'check --category'})"
        )
    if hasattr(dataset, "check_alignment_covers"):  # the instances clustered here are in the table too
        dataset.check_alignment_covers({args.category: ids})
    if len(ids) < (3 if k == "auto" else k):
        raise DatasetError(
            f"dataset {name} has {len(ids)} {args.split} instances of {args.category!r}; "
            f"--k {args.k} needs more (check --category, --split, dataset.root)"
        )
    clouds = {i: dataset.instance_model(args.category, i).points for i in ids}
    result = choose_templates(clouds, k, args.tau, args.points, args.seed)
    with out.writing():
        write_templates_yaml(
            out.path,
            args.category,
            result,
            {
                "dataset": name,
                "split": args.split,
                "k": len(result["templates"]),
                "tau": args.tau,
                "points": args.points,
                "seed": args.seed,
                "n_instances": len(ids),
            },
        )
    sil = ", ".join(f"K={kk}: {v:.3f}" for kk, v in result["silhouette"].items()) or "n/a"
    print(
        f"{args.category}: templates {result['templates']} (mean 1-F to medoid {result['mean_distance']:.3f}; "
        f"silhouette {sil}); wrote {out.out}"
    )
    return 0
