"""The nose/tail cues of the alignment study (``experiments/alignment/alignment_cues.py``, issue
25): equivariance, and the estimate on toy airplanes of unlike kinds whose Chamfer distances do not
say which end is the front."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments" / "alignment"))
import alignment_cues as ac  # noqa: E402  (the study's scripts)
from alignment_estimate import _index_of, estimate_table, resolve_cues, yaw_flip_hypotheses  # noqa: E402

from catpose.errors import DatasetError  # noqa: E402

pytestmark = pytest.mark.experiment


def _box(rng, n, centre, size):
    """n points on the surface of an axis-aligned box."""
    size = np.asarray(size, float)
    face = rng.integers(0, 6, n)
    p = rng.uniform(-0.5, 0.5, size=(n, 3))
    p[np.arange(n), face % 3] = np.where(face < 3, -0.5, 0.5)
    return p * size + np.asarray(centre, float)


def toy_airplane(kind: str, seed: int, n: int = 900) -> np.ndarray:
    """A nose-at-+x airplane of boxes, z up: fuselage, wing, tail fin and stabiliser at -x.
    ``jet``: wing aft of the middle; ``prop``: wing forward and a propeller disc (up and down)
    at the nose, so the wing sits where a jet's would be once turned round."""
    rng = np.random.default_rng(seed)
    s = 1.0 + 0.05 * rng.uniform(-1, 1)
    parts = [
        ((0, 0, 0), (2.0 * s, 0.22, 0.22), 0.35),  # fuselage
        ((-0.95 * s, 0, 0.30), (0.22, 0.04, 0.45), 0.08),  # fin, up only
        ((-0.92 * s, 0, 0.05), (0.2, 0.7, 0.04), 0.1),
    ]  # stabiliser
    if kind == "jet":
        parts.append(((-0.15, 0, 0), (0.5, 1.8, 0.05), 0.47))
    else:
        parts += [((0.35, 0, 0.05), (0.35, 1.9, 0.05), 0.4), ((1.02 * s, 0, 0), (0.03, 0.08, 0.7), 0.07)]
    pts = np.concatenate([_box(rng, max(10, int(n * w)), c, d) for c, d, w in parts])
    pts -= (pts.max(0) + pts.min(0)) / 2
    return pts / np.linalg.norm(pts, axis=1).max()


@pytest.mark.parametrize("flip", [False, True])
def test_cue_costs_depend_only_on_the_relative_rotation(flip):
    G = yaw_flip_hypotheses(flip)
    a, b = toy_airplane("jet", 1), toy_airplane("prop", 2)
    base = ac.cue_costs([a, b], G)
    for h in range(len(G)):
        moved = ac.cue_costs([a @ G[h].T, b @ G[h].T], G)
        for g in range(len(G)):
            g2 = _index_of(G[h] @ G[g] @ G[h].T, G)  # the same relative turn seen in the moved frames
            for name in ac.CUES:
                assert moved[name][0, 1, g2] == pytest.approx(base[name][0, 1, g], abs=1e-9)


def test_cues_are_signed_permutations_under_a_yaw_of_180_degrees():
    p = toy_airplane("prop", 3)
    turned = p * np.array([-1.0, -1.0, 1.0])
    np.testing.assert_allclose(ac.end_asymmetry(turned), ac.end_asymmetry(p)[[1, 0, 3, 2]], atol=1e-12)
    np.testing.assert_allclose(ac.end_span(turned), ac.end_span(p)[[1, 0, 3, 2]], atol=1e-12)
    np.testing.assert_allclose(ac.height_extremes(turned), -ac.height_extremes(p), atol=1e-12)
    # the fin reaches up at the tail (-x); the propeller reaches both ways at the nose (+x)
    asym = ac.end_asymmetry(p)
    assert asym[1] > 0.2 and abs(asym[0]) < asym[1] / 2


def test_coset_min_and_median_scaling():
    G = yaw_flip_hypotheses(True)
    C = np.random.default_rng(0).uniform(1, 2, size=(3, 3, len(G)))
    K = ac.coset_min(C, G)
    for g in range(len(G)):
        partner = _index_of(G[g] @ ac.YAW_180, G)
        np.testing.assert_allclose(K[:, :, g], np.minimum(C[:, :, g], C[:, :, partner]))
        np.testing.assert_allclose(K[:, :, g], K[:, :, partner])
    off = ac.median_scaled(C)[~np.eye(3, dtype=bool)]
    assert np.median(off) == pytest.approx(1.0)
    only_chamfer = ac.combined_costs(C, {"end_span": C * 5}, G, weights={"chamfer": 1.0})
    np.testing.assert_allclose(only_chamfer, ac.coset_min(ac.median_scaled(C), G))


def test_the_cues_find_the_front_of_unlike_airplanes_in_any_yaw():
    G = yaw_flip_hypotheses(False)
    truth = [0, 1, 2, 3, 2, 1, 3, 0]  # R_canonical_raw labels: each raw cloud is G[l]^T (canonical)
    kinds = ["jet", "prop", "jet", "prop", "prop", "jet", "prop", "jet"]
    clouds = [toy_airplane(k, seed) @ G[label] for seed, (k, label) in enumerate(zip(kinds, truth))]
    out = estimate_table(clouds, G, reference=0, refine=False, cues="ends")
    expected = [_index_of(G[truth[0]].T @ G[label], G) for label in truth]  # in the reference's frame
    np.testing.assert_array_equal(out["labels"], expected)
    assert (out["confidence"] > 0).all()


def test_auto_cues_are_the_categorys():
    assert resolve_cues("auto", "airplane") == "ends" and resolve_cues("auto", "chair") == "none"
    assert resolve_cues("none", "airplane") == "none"
    with pytest.raises(DatasetError, match="cues"):
        resolve_cues("height", "chair")
    with pytest.raises(DatasetError, match="resolve"):
        estimate_table([np.zeros((5, 3))] * 2, yaw_flip_hypotheses(False), cues="auto")
