"""Procedural, seeded category shapes for the embedded synthetic dataset.

Each ``make_<category>(rng)`` builds one random instance of its category from trimesh
primitives (boxes, cylinders, convex hulls, swept tubes, revolved profiles:
:mod:`catpose.datasets.shape_parts`) and returns it as a ``trimesh.Trimesh`` in the canonical frame: z up, front along +x (nose of the airplane, seat
front of the chair, hood of the car, handle of the mug), centred at its bounding-box centre and
scaled to a unit bounding sphere (:func:`catpose.geometry.normalize_to_unit_sphere`). Bottle,
bowl, can and plate are rotationally symmetric about z (:mod:`catpose.datasets.shapes_symmetric`);
this module holds the others and the registry :data:`SHAPES`.

Instances differ in part proportions, counts and shapes (engine count, leg count or pedestal,
armrests, handle shape, ...), so a template from the same category is not the instance.

Parts are concatenated, not booleaned, so the mesh has interior faces; use
:func:`catpose.datasets.meshio.sample_outer_surface` to sample the outer surface only.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from catpose import libm
from catpose.datasets.shape_parts import align_z, box, cylinder, finish, hull, posed, revolve_z, tube
from catpose.datasets.shapes_symmetric import make_bottle, make_bowl, make_can, make_plate
from catpose.geometry import apply_R, axis_angle_to_R, make_T, norm3

__all__ = [
    "SHAPES",
    "SYMMETRIC_CATEGORIES",
    "make_airplane",
    "make_chair",
    "make_car",
    "make_mug",
    "make_bottle",
    "make_bowl",
    "make_can",
    "make_plate",
    "make_shape",
]

#: Categories whose instances are rotationally symmetric about the z axis.
SYMMETRIC_CATEGORIES = frozenset({"bottle", "bowl", "can", "plate"})


def _wing(
    root_le: np.ndarray,
    root_chord: float,
    tip_le: np.ndarray,
    tip_chord: float,
    root_thick: float,
    tip_thick: float,
    thick_axis: int = 2,
) -> trimesh.Trimesh:
    """Trapezoidal lifting surface: hull of root and tip chords (along -x from the leading
    edges), thickened along ``thick_axis``."""
    e = np.zeros(3)
    e[thick_axis] = 1.0
    pts = []
    for le, chord, th in ((root_le, root_chord, root_thick), (tip_le, tip_chord, tip_thick)):
        le = np.asarray(le, dtype=np.float64)
        te = le - np.array([chord, 0.0, 0.0])
        mid = le - np.array([0.3 * chord, 0.0, 0.0])
        pts += [le, te, mid + 0.5 * th * e, mid - 0.5 * th * e]
    return hull(np.asarray(pts))


# --------------------------------------------------------------------------- asymmetric categories
# (the symmetric ones are catpose.datasets.shapes_symmetric's)


def make_airplane(rng: np.random.Generator) -> trimesh.Trimesh:
    """Airplane: nose at +x, wings along y, fin up (+z).

    Varies fuselage length/radius, wing planform (trapezoidal or delta), span, chord, taper,
    sweep, dihedral, height and position, tail layout (conventional, T-tail, or none for a delta)
    and fin shape, and the engine count (0, 2 or 4).
    """
    L = rng.uniform(1.6, 2.4)
    r = L * rng.uniform(0.045, 0.075)
    nose = L * rng.uniform(0.08, 0.16)
    tail = L * rng.uniform(0.2, 0.3)
    r_tail = r * rng.uniform(0.15, 0.4)
    # fuselage profile along its axis (s from tail at 0 to nose at L), revolved about x
    prof = [(0.0, 0.0), (r_tail, 0.0), (r, tail), (r, L - nose)]
    for a in np.linspace(0.0, np.pi / 2, 6)[1:]:
        prof.append((r * np.cos(a), L - nose + nose * np.sin(a)))
    prof[-1] = (0.0, L)
    fuselage = revolve_z(prof, sections=24)
    fuselage = posed(fuselage, make_T(axis_angle_to_R(np.array([0.0, 1.0, 0.0]), np.pi / 2), np.zeros(3)))
    parts = [fuselage]

    # main wings: trapezoidal (airliner / light aircraft) or delta (fighter: no tailplane, no pods)
    delta = rng.random() < 0.2
    if delta:
        half_span = L * rng.uniform(0.25, 0.38)
        root_chord = L * rng.uniform(0.38, 0.5)
        tip_chord = root_chord * rng.uniform(0.05, 0.15)
        sweep = libm.arctan((root_chord - tip_chord) * rng.uniform(0.8, 1.0) / half_span)
    else:
        half_span = L * rng.uniform(0.4, 0.65)
        root_chord = L * rng.uniform(0.14, 0.24)
        tip_chord = root_chord * rng.uniform(0.25, 0.6)
        sweep = np.deg2rad(rng.uniform(0.0, 38.0))
    dihedral = np.deg2rad(rng.uniform(-2.0, 8.0))
    z_w = r * rng.uniform(-0.6, 0.5)
    x_le = L * rng.uniform(0.5, 0.66)
    thick = root_chord * 0.12
    tip_dx = -half_span * libm.tan(sweep)
    tip_dz = half_span * libm.tan(dihedral)
    for s in (1.0, -1.0):
        parts.append(
            _wing(
                np.array([x_le, 0.0, z_w]),
                root_chord,
                np.array([x_le + tip_dx, s * half_span, z_w + tip_dz]),
                tip_chord,
                thick,
                thick * 0.5,
            )
        )

    # engines under the wings: 0, 2 or 4
    n_eng = 0 if delta else int(rng.choice([0, 2, 4], p=[0.25, 0.5, 0.25]))
    eng_r = r * rng.uniform(0.35, 0.55)
    eng_len = root_chord * rng.uniform(0.6, 0.9)
    stations = [0.35] if n_eng == 2 else ([0.3, 0.6] if n_eng == 4 else [])
    for f in stations:
        y = f * half_span
        x_le_y = x_le + f * tip_dx
        z_y = z_w + f * tip_dz - 0.5 * thick - 0.9 * eng_r
        for s in (1.0, -1.0):
            parts.append(
                cylinder(
                    np.array([x_le_y + 0.4 * eng_len, s * y, z_y]),
                    np.array([x_le_y - 0.6 * eng_len, s * y, z_y]),
                    eng_r,
                    sections=16,
                )
            )
            parts.append(box((0.4 * eng_len, 0.25 * eng_r, eng_r), (x_le_y - 0.2 * eng_len, s * y, z_y + 0.8 * eng_r)))

    # vertical fin at the tail
    fin_h = r * rng.uniform(2.0, 3.5)
    fin_chord = tail * rng.uniform(0.7, 1.0)
    fin_tip_chord = fin_chord * rng.uniform(0.35, 0.7)
    fin_sweep = fin_h * libm.tan(np.deg2rad(rng.uniform(20.0, 50.0)))
    fin_le = np.array([0.05 * L + fin_chord, 0.0, 0.5 * r])
    fin_tip = np.array([fin_le[0] - fin_sweep, 0.0, 0.5 * r + fin_h])
    parts.append(_wing(fin_le, fin_chord, fin_tip, fin_tip_chord, 0.12 * fin_chord, 0.06 * fin_chord, thick_axis=1))

    # horizontal stabiliser: conventional (on the fuselage) or T-tail (on top of the fin)
    t_tail = rng.random() < 0.3
    h_span = half_span * rng.uniform(0.28, 0.42)
    h_chord = tail * rng.uniform(0.5, 0.75)
    if t_tail:
        h_le = np.array([fin_tip[0], 0.0, fin_tip[2]])
        h_chord = min(h_chord, fin_tip_chord * 1.3)
    else:
        h_le = np.array([0.04 * L + h_chord, 0.0, 0.2 * r])
    h_sweep = h_span * libm.tan(sweep * rng.uniform(0.8, 1.2))
    for s in () if delta else (1.0, -1.0):
        parts.append(
            _wing(
                h_le,
                h_chord,
                h_le + np.array([-h_sweep, s * h_span, 0.0]),
                h_chord * 0.5,
                0.1 * h_chord,
                0.05 * h_chord,
            )
        )
    return finish(parts)


def make_chair(rng: np.random.Generator) -> trimesh.Trimesh:
    """Chair: seat facing +x, back at -x, legs down.

    Varies seat size/thickness/height, legs (3, 4 or 5, round or square, splayed) or a pedestal
    with a star base, back height/tilt/style (solid panel or posts with slats), and armrests.
    """
    w = rng.uniform(0.8, 1.1)  # seat width (y)
    d = rng.uniform(0.75, 1.0)  # seat depth (x)
    st = rng.uniform(0.05, 0.1)  # seat thickness
    h = rng.uniform(0.75, 1.0)  # seat top height
    parts = [box((d, w, st), (0.0, 0.0, h - st / 2))]
    z_under = h - st

    kind = rng.choice(["legs", "legs", "legs", "pedestal"])
    if kind == "legs":
        n_legs = int(rng.choice([3, 4, 4, 4, 5]))
        leg_r = rng.uniform(0.025, 0.05)
        splay = rng.uniform(0.0, 0.08)
        square = rng.random() < 0.5
        if n_legs == 4:
            inset = rng.uniform(0.04, 0.12)
            tops = [np.array([sx * (d / 2 - inset), sy * (w / 2 - inset), z_under]) for sx in (1, -1) for sy in (1, -1)]
        else:
            off = rng.uniform(0.0, 2 * np.pi / n_legs)
            rad = 0.4 * min(d, w)
            tops = [
                np.array(
                    [rad * np.cos(off + 2 * np.pi * k / n_legs), rad * np.sin(off + 2 * np.pi * k / n_legs), z_under]
                )
                for k in range(n_legs)
            ]
        for top in tops:
            out = np.array([top[0], top[1], 0.0])
            out /= max(norm3(out), 1e-9)
            foot = np.array([top[0], top[1], 0.0]) + splay * out
            if square:
                direction = foot - top
                length = norm3(direction)
                zaxis = direction / length
                R = align_z(zaxis)
                parts.append(box((2 * leg_r, 2 * leg_r, length), tuple((top + foot) / 2), R))
            else:
                parts.append(cylinder(top, foot, leg_r, sections=12))
        if rng.random() < 0.4 and n_legs == 4:  # stretchers between the legs
            zs = rng.uniform(0.15, 0.35) * h
            for sy in (1, -1):
                parts.append(box((d - 0.2, 0.03, 0.03), (0.0, sy * (w / 2 - 0.08), zs)))
    else:
        post_r = rng.uniform(0.04, 0.07)
        base_h = rng.uniform(0.08, 0.14)
        parts.append(cylinder(np.array([0.0, 0.0, base_h]), np.array([0.0, 0.0, z_under]), post_r))
        n_arms = int(rng.choice([4, 5]))
        arm_len = rng.uniform(0.35, 0.5)
        off = rng.uniform(0.0, 2 * np.pi / n_arms)
        for k in range(n_arms):
            a = off + 2 * np.pi * k / n_arms
            R = axis_angle_to_R(np.array([0.0, 0.0, 1.0]), a)
            parts.append(box((arm_len, 0.06, 0.05), tuple(apply_R(R, np.array([arm_len / 2, 0.0, base_h]))), R))
            tip = apply_R(R, np.array([arm_len, 0.0, 0.0]))
            parts.append(cylinder(tip + np.array([0, 0, base_h - 0.02]), tip, 0.03, sections=10))

    # back at -x, tilted backwards about y
    bh = rng.uniform(0.55, 1.1)
    tilt = np.deg2rad(rng.uniform(0.0, 20.0))
    bt = rng.uniform(0.04, 0.08)
    R_tilt = axis_angle_to_R(np.array([0.0, 1.0, 0.0]), -tilt)  # top moves towards -x
    base = np.array([-d / 2 + bt / 2, 0.0, h])

    def back_part(extents: tuple[float, float, float], local_center: np.ndarray) -> trimesh.Trimesh:
        return box(extents, tuple(base + apply_R(R_tilt, local_center)), R_tilt)

    if rng.random() < 0.5:
        bw = w * rng.uniform(0.8, 1.0)
        parts.append(back_part((bt, bw, bh), np.array([0.0, 0.0, bh / 2])))
    else:
        post = rng.uniform(0.04, 0.06)
        for sy in (1, -1):
            parts.append(back_part((bt, post, bh), np.array([0.0, sy * (w / 2 - post / 2), bh / 2])))
        rail_h = rng.uniform(0.08, 0.2)
        parts.append(back_part((bt, w, rail_h), np.array([0.0, 0.0, bh - rail_h / 2])))
        n_slats = int(rng.integers(1, 5))
        for y in np.linspace(-w / 2, w / 2, n_slats + 2)[1:-1]:
            parts.append(back_part((bt * 0.7, 0.05, bh - rail_h), np.array([0.0, y, (bh - rail_h) / 2])))

    if rng.random() < 0.4:  # armrests
        ah = rng.uniform(0.18, 0.3)
        aw = rng.uniform(0.05, 0.09)
        alen = d * rng.uniform(0.75, 0.95)
        for sy in (1, -1):
            y = sy * (w / 2 - aw / 2)
            parts.append(box((alen, aw, 0.04), (-d / 2 + alen / 2, y, h + ah)))
            parts.append(box((0.04, 0.04, ah), (-d / 2 + alen - 0.05, y, h + ah / 2)))
    return finish(parts)


def make_car(rng: np.random.Generator) -> trimesh.Trimesh:
    """Car: hood at +x, cabin set back, four wheels.

    Varies length/width/height, ground clearance, hood slope, cabin position/length/height and
    windshield rake, body style (sedan, hatchback, SUV), wheel radius/width and overhangs.
    """
    L = rng.uniform(3.4, 5.0)
    W = rng.uniform(1.55, 2.0)
    style = rng.choice(["sedan", "hatchback", "suv"])
    Hb = rng.uniform(0.4, 0.65) + (0.15 if style == "suv" else 0.0)
    clear = rng.uniform(0.15, 0.22) + (0.08 if style == "suv" else 0.0)
    wheel_r = rng.uniform(0.28, 0.36) + (0.04 if style == "suv" else 0.0)
    wheel_w = rng.uniform(0.18, 0.26)
    nose_drop = rng.uniform(0.05, 0.25)
    ztop = clear + Hb
    body_pts = []
    for y in (W / 2, -W / 2):
        yt = y * 0.94
        body_pts += [
            [-L / 2, y * 0.97, clear + 0.05],
            [-L / 2 + 0.1, y, clear],
            [L / 2 - 0.25, y, clear],
            [L / 2, y * 0.9, clear + 0.12],
            [L / 2, yt * 0.9, ztop - nose_drop - 0.05],
            [L / 2 - 0.3, yt, ztop - 0.3 * nose_drop],
            [-L / 2 + 0.05, yt, ztop],
            [-L / 2, y * 0.95, ztop - 0.08],
        ]
    parts = [hull(np.asarray(body_pts))]

    cabin_len = L * (rng.uniform(0.38, 0.5) if style == "sedan" else rng.uniform(0.5, 0.62))
    cabin_h = rng.uniform(0.38, 0.5) + (0.08 if style == "suv" else 0.0)
    rear_x = -L / 2 + (L * rng.uniform(0.15, 0.25) if style == "sedan" else rng.uniform(0.08, 0.2))
    front_x = rear_x + cabin_len
    rake = rng.uniform(0.35, 0.6) * cabin_len  # windshield run
    rear_rake = (rng.uniform(0.15, 0.35) if style == "sedan" else rng.uniform(0.02, 0.12)) * cabin_len
    cw = W * 0.9
    rw = W * rng.uniform(0.72, 0.82)
    cabin_pts = []
    for s in (1, -1):
        cabin_pts += [
            [rear_x, s * cw / 2, ztop - 0.02],
            [front_x, s * cw / 2, ztop - 0.3 * nose_drop - 0.02],
            [front_x - rake, s * rw / 2, ztop + cabin_h],
            [rear_x + rear_rake, s * rw / 2, ztop + cabin_h],
        ]
    parts.append(hull(np.asarray(cabin_pts)))

    front_over = rng.uniform(0.16, 0.24) * L
    rear_over = rng.uniform(0.13, 0.2) * L
    for x in (L / 2 - front_over, -L / 2 + rear_over):
        for s in (1, -1):
            y0 = s * (W / 2 - wheel_w / 2 + 0.03)
            parts.append(
                cylinder(
                    np.array([x, y0 - wheel_w / 2, wheel_r]),
                    np.array([x, y0 + wheel_w / 2, wheel_r]),
                    wheel_r,
                    sections=24,
                )
            )
    if style == "sedan" and rng.random() < 0.3:  # rear spoiler
        parts.append(box((0.12, W * 0.8, 0.04), (-L / 2 + 0.12, 0.0, ztop + 0.12)))
        for s in (1, -1):
            parts.append(box((0.05, 0.04, 0.12), (-L / 2 + 0.12, s * W * 0.3, ztop + 0.06)))
    return finish(parts)


def make_mug(rng: np.random.Generator) -> trimesh.Trimesh:
    """Mug: open cylindrical cup, handle on the +x side.

    Varies radius, height, taper, wall thickness, handle height/reach/thickness and handle shape
    (from elliptic to squarish, vertically offset).
    """
    Rb = rng.uniform(0.35, 0.5)
    H = rng.uniform(0.8, 1.3)
    Rt = Rb * rng.uniform(0.95, 1.15)
    t = rng.uniform(0.03, 0.05)
    tb = rng.uniform(0.05, 0.1)
    body = revolve_z([(0.0, 0.0), (Rb, 0.0), (Rt, H), (Rt - t, H), (Rb - t + (Rt - Rb) * tb / H, tb), (0.0, tb)])
    parts = [body]

    z_lo = H * rng.uniform(0.12, 0.3)
    z_hi = H * rng.uniform(0.7, 0.88)
    reach = H * rng.uniform(0.22, 0.38)
    tube_r = rng.uniform(0.03, 0.055)
    p = rng.uniform(2.0, 6.0)  # superellipse exponent: 2 = ellipse, large = squarish "D"
    theta = np.linspace(-np.pi / 2, np.pi / 2, 25)
    c, s = np.cos(theta), np.sin(theta)
    xe = libm.power(np.abs(c), 2.0 / p)
    ze = np.sign(s) * libm.power(np.abs(s), 2.0 / p)
    zc, a = 0.5 * (z_lo + z_hi), 0.5 * (z_hi - z_lo)
    z = zc + a * ze

    def wall_r(zz: np.ndarray) -> np.ndarray:
        return Rb + (Rt - Rb) * zz / H

    x = wall_r(z) - 0.5 * t + reach * xe
    path = np.stack([x, np.zeros_like(x), z], axis=1)
    parts.append(tube(path, tube_r))
    return finish(parts)


#: Category name -> generator ``make_<category>(rng) -> trimesh.Trimesh``.
SHAPES: dict[str, Callable[[np.random.Generator], trimesh.Trimesh]] = {
    "airplane": make_airplane,
    "chair": make_chair,
    "car": make_car,
    "mug": make_mug,
    "bottle": make_bottle,
    "bowl": make_bowl,
    "can": make_can,
    "plate": make_plate,
}


def make_shape(category: str, rng: np.random.Generator) -> trimesh.Trimesh:
    """Build one instance of ``category``; raises :class:`~catpose.errors.ConfigError` for an
    unknown category."""
    if category not in SHAPES:
        from catpose.errors import ConfigError

        raise ConfigError(f"unknown synthetic category {category!r}; choose from {sorted(SHAPES)}")
    return SHAPES[category](rng)
