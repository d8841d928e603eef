"""Procedural airplanes, drawn part by part from a random generator (``procedural.py
--category airplane`` writes them as a resampled root).

The kinds the shared ModelNet40 airplanes mix: airliners (swept low wings, two or four engine pods,
a conventional or a T tail), propeller planes (straight high or low wings, a propeller at the nose),
fighters (a long slim nose, swept or delta wings set aft, one or two fins), biplanes (two straight
wings joined by struts, a propeller) and gliders (long thin straight wings). The fuselage is a
cylinder with a cone at each end; wings, stabilisers and fins are thin tapered panels (the convex
hull of their eight corners). Every size is drawn from a range around the shared airplanes'
proportions. Each airplane is centred and scaled into the unit sphere in PointNet++'s resampled
layout: y up, the nose towards +z, the tail towards -z (the frame the verified alignment table puts
every shared airplane in), so its alignment row is the identity. Its kind is in
``mesh.metadata["kind"]``.
"""

from __future__ import annotations

import numpy as np
import trimesh
from procedural_chairs import rod  # the sibling script (procedural.py puts this folder on sys.path)

KINDS = ("airliner", "prop", "fighter", "biplane", "glider")
KIND_P = (0.35, 0.2, 0.2, 0.12, 0.13)


def panel(
    root_le: np.ndarray,
    chord_root: float,
    tip_le: np.ndarray,
    chord_tip: float,
    thickness: float,
    vertical: bool = False,
) -> trimesh.Trimesh:
    """A thin tapered panel: leading edges ``root_le`` and ``tip_le`` (3,), chords along -z (towards
    the tail) of ``chord_root`` and ``chord_tip``; ``thickness`` along y, or along x when
    ``vertical`` (a fin)."""
    back = np.array([0.0, 0.0, -1.0])
    across = np.array([1.0, 0.0, 0.0]) if vertical else np.array([0.0, 1.0, 0.0])
    corners = [root_le, root_le + chord_root * back, tip_le, tip_le + chord_tip * back]
    pts = [c + s * thickness / 2 * across for c in corners for s in (-1, 1)]
    return trimesh.convex.convex_hull(np.array(pts))


def wing_pair(
    y: float,
    z_root: float,
    half_span: float,
    chord_root: float,
    taper: float,
    sweep: float,
    dihedral: float,
    thickness: float,
) -> list[trimesh.Trimesh]:
    """Two mirrored panels from the centre line at height ``y``, root leading edge at ``z_root``,
    tips at +-``half_span`` along x, swept back by ``sweep`` (z at the tip) and raised by ``dihedral``."""
    out = []
    for s in (-1, 1):
        tip = np.array([s * half_span, y + dihedral, z_root - sweep])
        out.append(panel(np.array([0.0, y, z_root]), chord_root, tip, chord_root * taper, thickness))
    return out


def fuselage(length: float, radius: float, nose: float, tail: float, tail_rise: float) -> list[trimesh.Trimesh]:
    """A cylinder along z (nose at +z) with a cone of length ``nose`` in front and one of length
    ``tail`` behind, whose apex is raised by ``tail_rise``."""
    z0, z1 = -length / 2 + tail, length / 2 - nose
    parts = [trimesh.creation.cylinder(radius=radius, segment=[[0, 0, z0], [0, 0, z1]], sections=16)]
    front = trimesh.creation.cone(radius=radius, height=nose, sections=16)
    front.apply_translation([0, 0, z1])
    parts.append(front)
    back = trimesh.creation.cone(radius=radius, height=tail, sections=16)
    back.apply_transform(trimesh.transformations.rotation_matrix(np.pi, [1, 0, 0]))
    shear = np.eye(4)
    shear[1, 2] = -tail_rise / tail  # the apex (z = -tail) rises by tail_rise
    back.apply_transform(shear)
    back.apply_translation([0, 0, z0])
    parts.append(back)
    return parts


def tail_parts(
    rng: np.random.Generator, z_tail: float, radius: float, span: float, t_tail: bool, twin: bool, y_base: float
) -> list[trimesh.Trimesh]:
    """Horizontal stabilisers and one or two fins whose leading edges start at ``z_tail``."""
    fin_h = rng.uniform(0.18, 0.32)
    fin_c = rng.uniform(0.18, 0.3)
    th = 0.02
    fins = []
    xs = (-0.6 * radius, 0.6 * radius) if twin else (0.0,)
    for x in xs:
        lean = rng.uniform(0.08, 0.18)
        fins.append(
            panel(
                np.array([x, y_base, z_tail]),
                fin_c,
                np.array([x * 1.5, y_base + fin_h, z_tail - lean]),
                fin_c * rng.uniform(0.4, 0.7),
                th,
                vertical=True,
            )
        )
    y_stab = y_base + (fin_h if t_tail else 0.0)
    stab = wing_pair(
        y_stab,
        z_tail - (0.1 if t_tail else 0.02),
        span * rng.uniform(0.28, 0.4),
        fin_c * rng.uniform(0.7, 1.0),
        0.55,
        rng.uniform(0.03, 0.1),
        0.0,
        th,
    )
    return fins + stab


def propeller(rng: np.random.Generator, z: float, radius: float) -> list[trimesh.Trimesh]:
    """A spinner and two or three blades in the plane across the nose at ``z``."""
    r = rng.uniform(0.18, 0.28)
    parts = [trimesh.creation.icosphere(subdivisions=1, radius=radius * 0.7)]
    parts[0].apply_translation([0, 0, z])
    n = int(rng.choice([2, 3]))
    phase = rng.uniform(0, np.pi)
    for k in range(n):
        a = phase + 2 * np.pi * k / n
        parts.append(rod(np.array([0, 0, z]), np.array([r * np.cos(a), r * np.sin(a), z]), 0.015))
    return parts


def airplane(rng: np.random.Generator) -> trimesh.Trimesh:
    """One procedural airplane (fuselage about 2 units long), y up, nose towards +z."""
    kind = rng.choice(KINDS, p=KIND_P)
    L = 2.0
    if kind == "airliner":
        r, nose, tail = L * rng.uniform(0.045, 0.07), rng.uniform(0.12, 0.22), rng.uniform(0.3, 0.45)
        half_span = rng.uniform(0.8, 1.05)
        wing_y, wing_z = -0.5 * r, rng.uniform(0.0, 0.2)
        parts = fuselage(L, r, nose, tail, 0.6 * r)
        parts += wing_pair(
            wing_y,
            wing_z,
            half_span,
            rng.uniform(0.35, 0.5),
            rng.uniform(0.25, 0.4),
            rng.uniform(0.35, 0.6),
            rng.uniform(0.02, 0.08),
            0.03,
        )
        n_eng = 2 if rng.random() < 0.75 else 4
        for i in range(n_eng // 2):
            x = half_span * (0.35 + 0.3 * i)
            for s in (-1, 1):
                z = wing_z - 0.45 * x + 0.15
                parts.append(
                    trimesh.creation.cylinder(
                        radius=r * 0.45, segment=[[s * x, wing_y - 0.7 * r, z], [s * x, wing_y - 0.7 * r, z - 0.3]]
                    )
                )
        t_tail = rng.random() < 0.25
        parts += tail_parts(rng, -L / 2 + tail * 0.9, r, half_span, t_tail, False, 0.5 * r)
    elif kind == "prop":
        r, nose, tail = L * rng.uniform(0.05, 0.075), rng.uniform(0.1, 0.18), rng.uniform(0.5, 0.8)
        half_span = rng.uniform(0.85, 1.1)
        wing_y = (0.9 if rng.random() < 0.5 else -0.6) * r
        wing_z = L / 2 - nose - rng.uniform(0.3, 0.5)
        parts = fuselage(L, r, nose, tail, 0.4 * r)
        parts += wing_pair(
            wing_y,
            wing_z,
            half_span,
            rng.uniform(0.25, 0.35),
            rng.uniform(0.6, 1.0),
            rng.uniform(0.0, 0.08),
            rng.uniform(0.0, 0.06),
            0.03,
        )
        parts += propeller(rng, L / 2 + 0.02, r)
        parts += tail_parts(rng, -L / 2 + tail * 0.5, r, half_span, False, False, 0.4 * r)
    elif kind == "fighter":
        r, nose, tail = L * rng.uniform(0.045, 0.065), rng.uniform(0.4, 0.6), rng.uniform(0.1, 0.2)
        half_span = rng.uniform(0.45, 0.65)
        parts = fuselage(L, r, nose, tail, 0.0)
        delta = rng.random() < 0.4
        root = rng.uniform(0.7, 0.9) if delta else rng.uniform(0.4, 0.6)
        wing_z = -L / 2 + tail + root + rng.uniform(0.0, 0.15)
        parts += wing_pair(
            0.0,
            wing_z,
            half_span,
            root,
            0.1 if delta else rng.uniform(0.2, 0.4),
            root * 0.9 if delta else rng.uniform(0.3, 0.5),
            rng.uniform(-0.03, 0.02),
            0.03,
        )
        parts += tail_parts(rng, -L / 2 + tail + 0.3, r, half_span * 1.6, False, rng.random() < 0.5, 0.6 * r)
    elif kind == "biplane":
        r, nose, tail = L * rng.uniform(0.05, 0.07), rng.uniform(0.1, 0.15), rng.uniform(0.6, 0.8)
        half_span = rng.uniform(0.75, 0.95)
        wing_z = L / 2 - nose - rng.uniform(0.2, 0.35)
        chord = rng.uniform(0.22, 0.3)
        gap = rng.uniform(0.3, 0.45)
        parts = fuselage(L, r, nose, tail, 0.3 * r)
        parts += wing_pair(-0.8 * r, wing_z, half_span, chord, 1.0, 0.0, 0.0, 0.03)
        parts += wing_pair(
            -0.8 * r + gap,
            wing_z + rng.uniform(0.0, 0.1),
            half_span * rng.uniform(1.0, 1.1),
            chord,
            1.0,
            0.0,
            0.0,
            0.03,
        )
        for s in (-1, 1):
            for x in (0.35, 0.75):
                parts.append(
                    rod(
                        np.array([s * x * half_span, -0.8 * r, wing_z - chord / 2]),
                        np.array([s * x * half_span, -0.8 * r + gap, wing_z - chord / 2]),
                        0.012,
                    )
                )
        parts += propeller(rng, L / 2 + 0.02, r)
        parts += tail_parts(rng, -L / 2 + tail * 0.45, r, half_span, False, False, 0.3 * r)
    else:  # glider
        r, nose, tail = L * rng.uniform(0.035, 0.05), rng.uniform(0.2, 0.3), rng.uniform(0.8, 1.0)
        half_span = rng.uniform(1.3, 1.7)
        wing_z = L / 2 - nose - rng.uniform(0.3, 0.45)
        parts = fuselage(L, r, nose, tail, 0.0)
        parts += wing_pair(
            0.6 * r,
            wing_z,
            half_span,
            rng.uniform(0.16, 0.22),
            rng.uniform(0.4, 0.6),
            rng.uniform(0.0, 0.06),
            rng.uniform(0.02, 0.1),
            0.025,
        )
        parts += tail_parts(rng, -L / 2 + 0.25, r, half_span * 0.6, rng.random() < 0.5, False, 0.3 * r)
    mesh = trimesh.util.concatenate(parts)
    c = mesh.bounding_box.centroid
    mesh.apply_translation(-c)
    mesh.apply_scale(1.0 / np.linalg.norm(mesh.vertices, axis=1).max())
    mesh.metadata["kind"] = str(kind)
    return mesh
