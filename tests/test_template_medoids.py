"""K-medoids template selection on shapes whose clusters are known."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
import yaml

from catpose.bench.category import template_medoids as ts
from catpose.errors import ConfigError
from catpose.geometry import normalize_to_unit_sphere


def _sphere(rng, n, squash):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v * np.array([1.0, 1.0, squash])


def _box(rng, n, dims):
    face = rng.integers(0, 6, n)
    p = rng.uniform(-1, 1, size=(n, 3))
    p[np.arange(n), face % 3] = np.where(face < 3, -1.0, 1.0)
    return p * np.asarray(dims)


def _cylinder(rng, n, height):
    theta = rng.uniform(0, 2 * np.pi, n)
    return np.stack([np.cos(theta), np.sin(theta), rng.uniform(-height, height, n)], axis=1)


def shape_family(seed: int = 0, per_cluster: int = 4, n: int = 1200) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    clouds = {}
    for k in range(per_cluster):
        clouds[f"sphere{k}"] = _sphere(rng, n, 1.0 + 0.03 * k)
        clouds[f"box{k}"] = _box(rng, n, (1.0, 0.5 + 0.03 * k, 0.3))
        clouds[f"cyl{k}"] = _cylinder(rng, n, 2.5 + 0.1 * k)
    return {name: normalize_to_unit_sphere(p)[0] for name, p in clouds.items()}


def test_fscore_basics():
    rng = np.random.default_rng(0)
    P = _sphere(rng, 500, 1.0)
    assert ts.fscore(P, P, 0.01) == pytest.approx(1.0)
    assert ts.fscore(P, P + 10.0, 0.05) == 0.0
    D = ts.fscore_distances([P, P + 10.0, P], 0.05)
    assert D.shape == (3, 3) and np.allclose(D, D.T) and np.allclose(np.diag(D), 0)
    assert D[0, 2] == pytest.approx(0.0) and D[0, 1] == pytest.approx(1.0)


def test_medoids_one_per_cluster():
    clouds = shape_family()
    result = ts.choose_templates(clouds, k=3, tau=0.05, n_points=800, seed=0)
    families = sorted(t.rstrip("0123456789") for t in result["templates"])
    assert families == ["box", "cyl", "sphere"]
    for medoid, members in result["clusters"].items():  # every cluster is one family
        assert {m.rstrip("0123456789") for m in members} == {medoid.rstrip("0123456789")}
        assert len(members) == 4
    # deterministic: the same ids, clusters and distances on a second run
    again = ts.choose_templates(clouds, k=3, tau=0.05, n_points=800, seed=0)
    assert again["templates"] == result["templates"] and again["clusters"] == result["clusters"]
    np.testing.assert_array_equal(again["distances"], result["distances"])


@pytest.mark.parametrize("k", [1, 2, 3, 5])
def test_every_medoid_is_a_member_of_its_cluster_and_clusters_partition(k):
    clouds = shape_family(seed=1, per_cluster=3, n=600)
    result = ts.choose_templates(clouds, k=k, tau=0.05, n_points=600, seed=0)
    assert len(result["templates"]) == k == len(result["clusters"])
    members = [m for ms in result["clusters"].values() for m in ms]
    assert sorted(members) == sorted(clouds)  # every instance in exactly one cluster
    D, ids = result["distances"], result["ids"]
    for medoid, ms in result["clusters"].items():
        assert medoid in ms
        # each member is nearest to its own medoid (ties allowed)
        for m in ms:
            d_own = D[ids.index(m), ids.index(medoid)]
            assert all(d_own <= D[ids.index(m), ids.index(o)] + 1e-12 for o in result["clusters"])


def test_silhouette_picks_the_three_families():
    from sklearn.metrics import silhouette_score

    clouds = shape_family()
    result = ts.choose_templates(clouds, k="auto", tau=0.05, n_points=800, seed=0)
    assert len(result["templates"]) == 3 and max(result["silhouette"], key=result["silhouette"].get) == 3
    assert set(result["silhouette"]) == set(range(2, len(clouds)))
    labels = ts.select_medoids(result["distances"], 3)[1]
    assert result["silhouette"][3] == pytest.approx(silhouette_score(result["distances"], labels, metric="precomputed"))


def test_write_yaml_keeps_other_categories(tmp_path: Path):
    out = tmp_path / "templates" / "toy.yaml"
    out.parent.mkdir()
    out.write_text(yaml.safe_dump({"airplane": ["a1"]}))
    result = {"templates": ["c2", "c7"], "clusters": {"c2": ["c1", "c2"], "c7": ["c7"]}, "mean_distance": 0.1}
    ts.write_templates_yaml(out, "chair", result, {"k": 2, "tau": 0.05})
    doc = yaml.safe_load(out.read_text())
    assert doc == {"airplane": ["a1"], "chair": ["c2", "c7"]}
    assert "k=2" in out.read_text()
    with pytest.raises(ConfigError):
        ts.select_medoids(np.zeros((2, 2)), 3)


def test_cli_on_synthetic_dataset(tmp_path: Path):
    out = tmp_path / "t.yaml"
    rc = ts.main(
        [
            "dataset=synthetic",
            "dataset.categories=[mug]",
            "dataset.instances_per_category=3",
            "--category",
            "mug",
            "--k",
            "2",
            "--points",
            "300",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    doc = yaml.safe_load(out.read_text())
    assert list(doc) == ["mug"] and len(doc["mug"]) == 2


@pytest.mark.data
def test_cli_on_shared_modelnet40_airplanes(shared_data: Path, tmp_path: Path):
    out = tmp_path / "airplane.yaml"
    table = Path(__file__).resolve().parents[1] / "results/alignment/modelnet40_airplane.csv"
    rc = ts.main(
        [
            "dataset=modelnet40",
            f"dataset.root={shared_data / 'ModelNet40'}",
            f"dataset.alignment_table={table}",
            "--category",
            "airplane",
            "--k",
            "2",
            "--points",
            "512",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    chosen = yaml.safe_load(out.read_text())["airplane"]
    assert len(set(chosen)) == 2 and all(c.startswith("airplane_000") for c in chosen)


def test_written_file_is_a_hydra_group_for_dataset_templates(tmp_path: Path):
    from hydra import compose, initialize_config_module

    result = {
        "templates": ["chair_0002", "chair_0001"],
        "clusters": {"chair_0002": ["chair_0002"], "chair_0001": ["chair_0001"]},
        "mean_distance": 0.0,
    }
    ts.write_templates_yaml(tmp_path / "templates" / "mn_chair.yaml", "chair", result, {"k": 2})
    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose(
            "run", overrides=["dataset=modelnet40", "+templates=mn_chair", f"hydra.searchpath=[file://{tmp_path}]"]
        )
    assert list(cfg.dataset.templates.chair) == ["chair_0002", "chair_0001"]


def test_out_is_required_and_unaligned_data_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit):  # argparse: --out is required, nothing is written into the package
        ts.main(["dataset=synthetic", "--category", "mug"])
    capsys.readouterr()
    root = tmp_path / "mn"
    (root / "chair" / "train").mkdir(parents=True)
    from catpose.bench.cli import main

    assert (
        main(
            [
                "templates",
                "dataset=modelnet40",
                f"dataset.root={root}",
                "--category",
                "chair",
                "--out",
                str(tmp_path / "t.yaml"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench templates: error: ") and "align.py" in err[0]
    assert not (tmp_path / "t.yaml").exists()


def test_bad_dataset_root_is_one_line(tmp_path, capsys):
    from catpose.bench.cli import main

    assert (
        main(
            [
                "templates",
                "--category",
                "chair",
                "dataset=modelnet40",
                f"dataset.root={tmp_path / 'nope'}",
                "--out",
                str(tmp_path / "t.yaml"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bench templates: error: ") and "nope" in err[0]


# PAM itself (ts.pam): against an exhaustive search and, where the GPL ``kmedoids`` package is
# installed (not by ``make setup``), against its Rust PAM


def _distances(seed: int, n: int, clustered: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 3))
    if clustered:
        X[: n // 3] += 6.0
        X[n // 3 : 2 * n // 3] -= 6.0
    return np.linalg.norm(X[:, None] - X[None], axis=2)


def _loss(D: np.ndarray, medoids) -> float:
    return float(D[:, list(medoids)].min(axis=1).sum())


def _optimum(D: np.ndarray, k: int) -> float:
    return min(_loss(D, m) for m in itertools.combinations(range(len(D)), k))


@pytest.mark.parametrize("seed", range(12))
def test_pam_ends_in_a_local_optimum_no_single_swap_improves(seed):
    D = _distances(seed, 14, clustered=seed % 2 == 0)
    k = 2 + seed % 3
    medoids = ts.pam(D, k)
    loss = _loss(D, medoids)
    assert len(set(medoids.tolist())) == k
    for slot, j in itertools.product(range(k), range(len(D))):
        if j in medoids:
            continue
        swapped = medoids.copy()
        swapped[slot] = j
        assert _loss(D, swapped) >= loss - 1e-9, (slot, j)


@pytest.mark.parametrize("seed", range(8))
def test_pam_on_separated_clusters_reaches_the_exhaustive_optimum(seed):
    D = _distances(seed, 12, clustered=True)
    assert _loss(D, ts.pam(D, 3)) == pytest.approx(_optimum(D, 3), rel=1e-12)


def test_pam_build_takes_the_best_first_medoid_and_k_1_and_n():
    D = _distances(0, 9, clustered=False)
    assert ts.pam(D, 1).tolist() == [int(np.argmin(D.sum(axis=0)))]
    assert _loss(D, ts.pam(D, 1)) == pytest.approx(_optimum(D, 1))
    assert sorted(ts.pam(D, 9).tolist()) == list(range(9))


def test_pam_duplicate_points_and_ties_stay_deterministic():
    X = np.repeat(np.array([[0.0, 0, 0], [5, 0, 0], [0, 5, 0]]), 3, axis=0)  # three triples of equal points
    D = np.linalg.norm(X[:, None] - X[None], axis=2)
    medoids = ts.pam(D, 3)
    assert _loss(D, medoids) == 0.0 and sorted(medoids.tolist()) == [0, 3, 6]  # the lowest index of each triple
    assert ts.pam(D, 3).tolist() == medoids.tolist()


@pytest.mark.parametrize("seed", range(40))
def test_pam_same_loss_as_the_kmedoids_package(seed):
    kmedoids = pytest.importorskip("kmedoids")
    rng = np.random.default_rng(1000 + seed)
    n, k = int(rng.integers(6, 40)), int(rng.integers(2, 6))
    D = _distances(1000 + seed, n, clustered=seed % 2 == 1)
    ref = kmedoids.pam(D, k, max_iter=100, init="build", random_state=None)
    assert _loss(D, ts.pam(D, k)) == pytest.approx(float(ref.loss), rel=1e-12)
