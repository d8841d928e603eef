"""Shape cues that tell nose from tail where the symmetric Chamfer distance cannot.

Issue 25: on the shared airplanes the Chamfer consensus of ``alignment_estimate.estimate_table``
found every fuselage axis but turned nose against tail: a propeller plane turned 180 degrees fits
a jet about as well as the right way round (the wings move to where the other's wings are). What
the ends of a shape look like is more alike across a category than where its bulk lies. Each cue
is measured in the frame a hypothesis puts a cloud in (z up), at the four horizontal ends
(+x, -x, +y, -y; an end is the outer ``fraction`` of the cloud's extent along that axis):

- extremes: the mean x and y of the highest 3% and of the lowest 3% of the points (a tail fin
  rises at the rear of most airplanes, a chair back at the rear of a chair);
- end asymmetry: in each end, how much farther the points reach above their median height than
  below it (a fin reaches up only; a propeller, a nose or a biplane's wings reach both ways);
- end span: in each end, the extent across (the horizontal stabiliser at an airplane's tail, the
  narrow nose; the seat's width against the back's).

The cues are *equivariant* under the hypothesis group (yaws by 90 degrees, the up axis turned
over): a common rotation of two clouds permutes (and negates) their entries alike, so the L1
distance between two instances' cues depends only on their relative rotation, like the Chamfer
distance, and the costs fit ``alignment_estimate.synchronize`` as they are.

:func:`combined_costs` adds them to the Chamfer costs, each divided by its median over all pairs
and hypotheses; the Chamfer term keeps only the main-axis information (the lower of a hypothesis
and its 180-degree yaw: :func:`coset_min`), so nose against tail is left to the cues. The cues
and :data:`WEIGHTS` were chosen on 161 development airplanes of the ModelNet40 train split that
are not in the shared set (checked by eye; never the verified tables): docs/category-level.md.
"""

from __future__ import annotations

import numpy as np

from catpose.geometry import apply_R, matmul3

#: fraction of the points (highest / lowest) whose mean position is the ``extremes`` cue
EXTREME_FRACTION = 0.03
#: outer fraction of a cloud's extent along an axis that is an "end" (asymmetry; span)
ASYMMETRY_END = 0.12
SPAN_END = 0.15
#: weights of :func:`combined_costs` (chosen on the development airplanes, docs/category-level.md)
WEIGHTS = {"chamfer": 1.0, "extremes": 1.0, "end_asymmetry": 3.0, "end_span": 2.0}


def height_extremes(points: np.ndarray, fraction: float = EXTREME_FRACTION) -> np.ndarray:
    """(4,): mean x, mean y of the highest ``fraction`` of the points, then of the lowest: the
    points at or above the k-th highest z (at or below the k-th lowest), k = max(3, fraction N),
    so that points tied in height are all in or all out, whatever their order."""
    p = np.asarray(points, float)
    k = max(3, int(round(fraction * len(p))))
    z = np.sort(p[:, 2])
    top, bottom = p[p[:, 2] >= z[-k]], p[p[:, 2] <= z[k - 1]]
    return np.array([top[:, 0].mean(), top[:, 1].mean(), bottom[:, 0].mean(), bottom[:, 1].mean()])


def _ends(p: np.ndarray, fraction: float):
    """Yield (axis, mask) for the ends +x, -x, +y, -y of ``p`` (N, 3): the points within the
    outer ``fraction`` of its extent along x (then y)."""
    for axis in (0, 1):
        x = p[:, axis]
        lo, hi = float(x.min()), float(x.max())
        reach = fraction * (hi - lo)
        yield axis, x >= hi - reach
        yield axis, x <= lo + reach


def end_asymmetry(points: np.ndarray, fraction: float = ASYMMETRY_END) -> np.ndarray:
    """(4,): at the ends +x, -x, +y, -y, ``(max z - median z) - (median z - min z)`` of the end's
    points (0 for an end with fewer than 3 points)."""
    p = np.asarray(points, float)
    out = []
    for _, m in _ends(p, fraction):
        z = p[m, 2]
        if len(z) < 3:
            out.append(0.0)
            continue
        med = float(np.median(z))
        out.append((float(z.max()) - med) - (med - float(z.min())))
    return np.array(out)


def end_span(points: np.ndarray, fraction: float = SPAN_END) -> np.ndarray:
    """(4,): at the ends +x, -x, +y, -y, the extent of the end's points across (along y at the x
    ends, along x at the y ends; 0 for an end with fewer than 3 points)."""
    p = np.asarray(points, float)
    out = []
    for axis, m in _ends(p, fraction):
        across = p[m, 1 - axis]
        out.append(float(across.max() - across.min()) if len(across) >= 3 else 0.0)
    return np.array(out)


CUES = {"extremes": height_extremes, "end_asymmetry": end_asymmetry, "end_span": end_span}


def cue_costs(clouds: list[np.ndarray], hypotheses: np.ndarray) -> dict[str, np.ndarray]:
    """Pairwise costs of each cue of :data:`CUES`, each (N, N, H) like
    :func:`catpose.datasets.alignment.pairwise_costs`: ``C[i, j, g]`` is the mean absolute
    difference between the cue of cloud ``i`` turned by hypothesis ``g`` and that of cloud ``j``
    as it is. Zero on the diagonal."""
    N, H = len(clouds), len(hypotheses)
    out = {}
    feats = {name: np.zeros((N, H, 4)) for name in CUES}
    for i, cloud in enumerate(clouds):
        for g, R in enumerate(hypotheses):
            turned = apply_R(R, cloud)
            for name, fn in CUES.items():
                feats[name][i, g] = fn(turned)
    for name, f in feats.items():
        C = np.zeros((N, N, H))
        for i in range(N):
            for j in range(N):
                if i != j:
                    C[i, j] = np.abs(f[i] - f[j, 0][None]).mean(axis=1)
        out[name] = C
    return out


def _index_of(R: np.ndarray, group: np.ndarray) -> int:
    return int(np.argmin(np.abs(group - R).reshape(len(group), -1).max(axis=1)))


YAW_180 = np.diag([-1.0, -1.0, 1.0])


def coset_min(C: np.ndarray, hypotheses: np.ndarray, turn: np.ndarray = YAW_180) -> np.ndarray:
    """``C`` (N, N, H) with each hypothesis' cost replaced by the lower of it and of the same
    hypothesis followed by ``turn`` (default a 180-degree yaw; it must be in the group): the costs
    then say which axis is the main one, and nothing about which end is the front."""
    H = len(hypotheses)
    partner = [_index_of(matmul3(hypotheses[g], turn), hypotheses) for g in range(H)]
    return np.minimum(C, C[:, :, partner])


def median_scaled(C: np.ndarray) -> np.ndarray:
    """``C`` (N, N, H) divided by the median of its off-diagonal entries (1 if that is 0)."""
    N = len(C)
    off = C[~np.eye(N, dtype=bool)]
    m = float(np.median(off)) if off.size else 1.0
    return C / (m if m > 0 else 1.0)


def combined_costs(
    C_chamfer: np.ndarray, cues: dict[str, np.ndarray], hypotheses: np.ndarray, weights: dict[str, float] | None = None
) -> np.ndarray:
    """The costs ``alignment_estimate.synchronize`` minimises with the cues:
    ``w_chamfer * coset_min(Chamfer) + sum_cue w_cue * cue``, each term scaled by its median
    (:func:`median_scaled`; the Chamfer term before :func:`coset_min`). ``cues`` is
    :func:`cue_costs`' dict; ``weights`` default to :data:`WEIGHTS` (a cue without a weight is
    left out). All arrays are (N, N, H)."""
    w = dict(WEIGHTS if weights is None else weights)
    C = float(w.get("chamfer", 0.0)) * coset_min(median_scaled(C_chamfer), hypotheses)
    for name, Cc in cues.items():
        if w.get(name):
            C = C + float(w[name]) * median_scaled(Cc)
    return C
