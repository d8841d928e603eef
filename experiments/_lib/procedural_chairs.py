"""Procedural chairs, drawn part by part from a random generator (``procedural.py
--category chair`` writes them as a resampled root).

A seat (box, optional cushion), one of four bases (four legs, optionally splayed and joined by
stretchers; an office pedestal on a five-spoke star; two side panels; a cantilever sled), one of
four backs (solid panel, vertical slats or horizontal rails between two posts, a ladder frame),
tilted back 0-20 deg, and arms on some. Every size is drawn from a range around the shared
ModelNet40 chairs' proportions (seat top at 0.40-0.55 of the height, back 0.35-0.60 of it). The
chair stands in PointNet++'s resampled layout: y up, the back towards +z as in the shared chairs, so
its alignment row is the identity. None is a ModelNet40 shape, so a development set of them can be
as large as a choice needs (docs/choosing-defaults.md).
"""

from __future__ import annotations

import numpy as np
import trimesh


def box(lo: np.ndarray, hi: np.ndarray) -> trimesh.Trimesh:
    """An axis-aligned box between corners ``lo`` and ``hi`` (3,), y up, z towards the back."""
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    b = trimesh.creation.box(extents=hi - lo)
    b.apply_translation((lo + hi) / 2)
    return b


def rod(a: np.ndarray, b: np.ndarray, radius: float) -> trimesh.Trimesh:
    """A cylinder of ``radius`` from point ``a`` to point ``b`` (3,)."""
    return trimesh.creation.cylinder(radius=radius, segment=np.stack([a, b]), sections=12)


def base_parts(rng: np.random.Generator, w: float, d: float, h_seat: float) -> list[trimesh.Trimesh]:
    """The parts under a seat of width ``w`` (x), depth ``d`` (z) whose underside is at ``h_seat``."""
    kind = rng.choice(["legs", "pedestal", "panels", "sled"], p=[0.55, 0.2, 0.12, 0.13])
    parts = []
    if kind == "legs":
        t = rng.uniform(0.03, 0.07)
        inset = rng.uniform(0.0, 0.08)
        splay = rng.uniform(0.0, 0.08) if rng.random() < 0.4 else 0.0
        round_legs = rng.random() < 0.5
        corners = [(sx, sz) for sx in (-1, 1) for sz in (-1, 1)]
        for sx, sz in corners:
            top = np.array([sx * (w / 2 - inset - t), h_seat, sz * (d / 2 - inset - t)])
            foot = top + np.array([sx * splay, -h_seat, sz * splay])
            if round_legs:
                parts.append(rod(foot, top, t / 2 + 0.005))
            else:
                parts.append(box(foot - [t / 2, 0, t / 2], top + [t / 2, 0, t / 2]))
        if rng.random() < 0.45:  # stretchers between the legs
            y = rng.uniform(0.12, 0.35) * h_seat
            f = 1 - y / h_seat
            for sx in (-1, 1):
                x = sx * (w / 2 - inset - t + splay * f)
                parts.append(
                    rod(
                        np.array([x, y, -(d / 2 - inset - t + splay * f)]),
                        np.array([x, y, d / 2 - inset - t + splay * f]),
                        t / 3,
                    )
                )
            if rng.random() < 0.5:
                z = -(d / 2 - inset - t + splay * f)
                parts.append(rod(np.array([-(w / 2 - inset - t), y, z]), np.array([w / 2 - inset - t, y, z]), t / 3))
    elif kind == "pedestal":
        r = rng.uniform(0.03, 0.05)
        foot_y = rng.uniform(0.05, 0.1)
        parts.append(rod(np.array([0, foot_y, 0]), np.array([0, h_seat, 0]), r))
        spoke = rng.uniform(0.3, 0.45) * max(w, d)
        phase = rng.uniform(0, 2 * np.pi)
        for k in range(5):
            a = phase + 2 * np.pi * k / 5
            end = np.array([spoke * np.cos(a), 0.04, spoke * np.sin(a)])
            parts.append(rod(np.array([0, foot_y, 0]), end, 0.025))
            parts.append(
                trimesh.creation.icosphere(subdivisions=1, radius=0.035).apply_translation(end - [0, 0.005, 0])
            )
    elif kind == "panels":
        t = rng.uniform(0.03, 0.06)
        for sx in (-1, 1):
            x = sx * (w / 2 - t / 2)
            parts.append(box(np.array([x - t / 2, 0, -d / 2]), np.array([x + t / 2, h_seat, d / 2])))
    else:  # sled: a runner and two uprights each side
        r = rng.uniform(0.015, 0.03)
        for sx in (-1, 1):
            x = sx * (w / 2 - 0.04)
            front, back = np.array([x, r, -d / 2 - 0.03]), np.array([x, r, d / 2])
            parts.append(rod(front, back, r))
            parts.append(rod(front, np.array([x, h_seat, -d / 2 + 0.06]), r))
            parts.append(rod(back, np.array([x, h_seat, d / 2 - 0.06]), r))
    return parts


def back_parts(rng: np.random.Generator, w: float, d: float, y0: float, h_back: float) -> list[trimesh.Trimesh]:
    """A back of height ``h_back`` standing at the seat's rear edge (z = ``d`` / 2) from ``y0``,
    tilted backwards about x by 0-20 deg."""
    kind = rng.choice(["panel", "slats", "rails", "ladder"], p=[0.4, 0.25, 0.2, 0.15])
    t = rng.uniform(0.03, 0.08)
    bw = w * rng.uniform(0.75, 1.0)
    z0 = d / 2 - t / 2
    parts = []
    if kind == "panel":
        gap = rng.uniform(0.0, 0.15) * h_back if rng.random() < 0.4 else 0.0  # open below the panel
        parts.append(box(np.array([-bw / 2, y0 + gap, z0 - t / 2]), np.array([bw / 2, y0 + h_back, z0 + t / 2])))
        if gap > 0:
            for sx in (-1, 1):
                parts.append(
                    box(np.array([sx * bw / 2 - 0.03, y0, z0 - t / 2]), np.array([sx * bw / 2, y0 + gap, z0 + t / 2]))
                )
    else:
        post = rng.uniform(0.03, 0.05)
        for sx in (-1, 1):
            x = sx * (bw / 2 - post / 2)
            parts.append(
                box(np.array([x - post / 2, y0, z0 - post / 2]), np.array([x + post / 2, y0 + h_back, z0 + post / 2]))
            )
        top = rng.uniform(0.05, 0.15)
        parts.append(
            box(np.array([-bw / 2, y0 + h_back - top, z0 - t / 2]), np.array([bw / 2, y0 + h_back, z0 + t / 2]))
        )
        inner = bw - 2 * post
        if kind == "slats":
            n = int(rng.integers(2, 6))
            sw = inner / (2 * n + 1)
            for k in range(n):
                x = -inner / 2 + sw * (2 * k + 1)
                parts.append(box(np.array([x, y0, z0 - t / 4]), np.array([x + sw, y0 + h_back - top, z0 + t / 4])))
        elif kind == "rails":
            n = int(rng.integers(1, 4))
            for k in range(n):
                y = y0 + (h_back - top) * (k + 1) / (n + 1)
                parts.append(box(np.array([-bw / 2, y - 0.03, z0 - t / 4]), np.array([bw / 2, y + 0.03, z0 + t / 4])))
        else:  # ladder: a second, lower wide rail
            y = y0 + rng.uniform(0.25, 0.5) * h_back
            parts.append(box(np.array([-bw / 2, y - top / 2, z0 - t / 2]), np.array([bw / 2, y + top / 2, z0 + t / 2])))
    tilt = np.radians(rng.uniform(0.0, 20.0))
    R = trimesh.transformations.rotation_matrix(tilt, [1, 0, 0], point=[0, y0, d / 2])
    for p in parts:
        p.apply_transform(R)
    return parts


def arm_parts(rng: np.random.Generator, w: float, d: float, y_seat: float) -> list[trimesh.Trimesh]:
    """Two arm rests over the seat's sides."""
    h = rng.uniform(0.18, 0.3)
    t = rng.uniform(0.04, 0.08)
    parts = []
    for sx in (-1, 1):
        x = sx * (w / 2 - t / 2)
        parts.append(
            box(np.array([x - t / 2, y_seat + h - 0.04, -d / 2 + 0.05]), np.array([x + t / 2, y_seat + h, d / 2]))
        )
        parts.append(box(np.array([x - 0.02, y_seat, -d / 2 + 0.08]), np.array([x + 0.02, y_seat + h, -d / 2 + 0.12])))
    return parts


def chair(rng: np.random.Generator) -> trimesh.Trimesh:
    """One procedural chair (about 1.5-1.8 units tall), y up, back towards +z, front towards -z."""
    w, d = rng.uniform(0.85, 1.2), rng.uniform(0.8, 1.15)
    height = rng.uniform(1.45, 1.8)
    y_top = height * rng.uniform(0.40, 0.55)
    t_seat = rng.uniform(0.05, 0.14)
    parts = [box(np.array([-w / 2, y_top - t_seat, -d / 2]), np.array([w / 2, y_top, d / 2]))]
    if rng.random() < 0.3:  # a cushion
        c = rng.uniform(0.04, 0.1)
        parts.append(
            box(np.array([-w / 2 + 0.03, y_top, -d / 2 + 0.03]), np.array([w / 2 - 0.03, y_top + c, d / 2 - 0.08]))
        )
    parts += base_parts(rng, w, d, y_top - t_seat)
    parts += back_parts(rng, w, d, y_top, height - y_top)
    if rng.random() < 0.3:
        parts += arm_parts(rng, w, d, y_top)
    return trimesh.util.concatenate(parts)
