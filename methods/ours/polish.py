"""A pose polished on the depth check's own cost: a local search in the template's frame.

ICP moves a pose to fit the input points; the depth check then judges it by what the camera
would see. The two disagree on a near-symmetric object: ICP can move a right pose to where its
half turn costs less (the TYO-L basket under the earlier depth tolerance 0.1: the truth cost 0.518
on the final lattice, refined by ICP 0.661, its half turn 0.655). :func:`polish` instead walks a pose downhill on the depth cost
itself: at each level it tries the 12 moves of :func:`moves` (a turn by ``+-deg`` about each
template axis through the template origin, a shift by ``+-shift`` along each), takes the best
while it lowers the cost (at most :data:`STEPS` per level), then halves both steps.

The moves use the C library's sine and cosine (the same bits on every CPU) and the verifier's
scores are deterministic, so a polished pose is too. Cost: up to ``12 * STEPS * levels`` poses
scored per polished pose.
"""

from __future__ import annotations

import math

import numpy as np

from catpose.geometry import compose_T

__all__ = ["STEPS", "moves", "polish"]

#: the most accepted moves per level of :func:`polish`
STEPS = 6


def moves(deg: float, shift: float) -> np.ndarray:
    """(12, 4, 4) rigid moves of the template frame: turns by ``+deg`` and ``-deg`` (degrees) about
    its x, y and z axes through its origin and shifts by ``+shift`` and ``-shift`` (its unit) along
    them, interleaved per axis (turn +, shift +, turn -, shift -)."""
    out = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            a = math.radians(sign * deg)
            c, s = math.cos(a), math.sin(a)
            i, j = (axis + 1) % 3, (axis + 2) % 3
            F = np.eye(4)
            F[i, i] = F[j, j] = c
            F[j, i], F[i, j] = s, -s
            out.append(F)
            F = np.eye(4)
            F[axis, 3] = sign * shift
            out.append(F)
    return np.stack(out)


def polish(verifier, T: np.ndarray, score: float, levels: int, deg: float, shift: float) -> tuple[np.ndarray, float]:
    """``T`` (4, 4, ``T_template_camera``) moved downhill on ``verifier.scores`` (a
    :class:`~catpose.methods.ours.check.DepthVerifier`), from its ``score``: ``levels`` levels
    of :func:`moves`, the first with ``deg`` degrees and ``shift`` (template unit), each next
    with half. Returns the pose and its score (``T`` and ``score`` when no move lowers it)."""
    T = np.asarray(T, dtype=np.float64)
    for level in range(int(levels)):
        F = moves(deg / 2**level, shift / 2**level)
        for _ in range(STEPS):
            tried = np.stack([compose_T(f, T) for f in F])
            scores = verifier.scores(tried)
            k = int(np.argmin(scores))
            if not scores[k] < score:
                break
            T, score = tried[k], float(scores[k])
    return T, score
