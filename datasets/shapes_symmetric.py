"""The rotationally symmetric categories of the synthetic set (bottle, bowl, can, plate):
surfaces of revolution about +z of a seeded (radius, height) profile
(:func:`catpose.datasets.shape_parts.revolve_z`), normalised to the unit bounding sphere. The
registry of every category is :mod:`catpose.datasets.shapes`.
"""

from __future__ import annotations

import numpy as np
import trimesh

from catpose import libm
from catpose.datasets.shape_parts import finish, revolve_z

__all__ = ["make_bottle", "make_bowl", "make_can", "make_plate"]


def make_bottle(rng: np.random.Generator) -> trimesh.Trimesh:
    """Bottle (symmetric about z): varies body radius/height, shoulder length and curvature,
    neck radius/height and cap."""
    Rb = rng.uniform(0.25, 0.4)
    Hb = rng.uniform(0.6, 1.2)
    hs = rng.uniform(0.1, 0.35)
    rn = Rb * rng.uniform(0.25, 0.45)
    hn = rng.uniform(0.1, 0.35)
    curve = rng.uniform(1.0, 3.0)  # 1: conical shoulder, 2: elliptic, 3: boxy
    prof = [(0.0, 0.0), (Rb * 0.92, 0.0), (Rb, 0.04), (Rb, Hb)]
    for u in np.linspace(0.0, 1.0, 8)[1:]:
        prof.append((rn + (Rb - rn) * libm.power(1 - libm.power(u, curve), 1 / curve), Hb + hs * u))
    z = Hb + hs + hn
    prof.append((rn, z))
    rc, hc = rn * rng.uniform(1.05, 1.25), rng.uniform(0.06, 0.14)
    prof += [(rc, z), (rc, z + hc), (0.0, z + hc)]
    return finish([revolve_z(prof)])


def make_bowl(rng: np.random.Generator) -> trimesh.Trimesh:
    """Bowl (symmetric about z): open shell; varies rim radius, depth, wall curvature,
    thickness and the presence/size of a foot ring."""
    R = rng.uniform(0.8, 1.0)
    D = R * rng.uniform(0.25, 0.65)
    t = rng.uniform(0.03, 0.05)
    k = rng.uniform(1.5, 3.5)
    rs = np.linspace(0.0, 1.0, 16)
    prof: list[tuple[float, float]] = []
    if rng.random() < 0.7:
        Rf, fh = R * rng.uniform(0.3, 0.5), rng.uniform(0.04, 0.1)
        prof += [(0.0, -fh), (Rf, -fh), (Rf * 0.97, 0.0)]
        start = Rf * 0.97 / R
    else:
        prof += [(0.0, 0.0)]
        start = 0.0
    for u in rs[rs > start]:
        prof.append((R * u, D * libm.power(u, k)))
    Ri = R - t
    for u in rs[::-1][:-1]:
        prof.append((Ri * u, t + (D - t) * libm.power(u, k)))
    prof.append((0.0, t))
    return finish([revolve_z(prof)])


def make_can(rng: np.random.Generator) -> trimesh.Trimesh:
    """Can (symmetric about z): varies radius/height ratio (tuna tin to tall soda can), the
    necked-in top, rim height and lid recess, and the bottom dome."""
    R = rng.uniform(0.3, 0.45)
    H = R * rng.uniform(0.8, 3.2)
    neck = rng.uniform(0.85, 1.0)
    neck_h = H * rng.uniform(0.03, 0.1)
    lip = rng.uniform(0.01, 0.03)
    recess = rng.uniform(0.015, 0.04)
    dome = rng.uniform(0.0, 0.05)
    rim_h = rng.uniform(0.005, 0.02)
    Rt = R * neck
    prof = [
        (0.0, dome),
        (R * 0.85, 0.0),
        (R * 0.97, 0.01),
        (R, 0.03),
        (R, H - neck_h),
        (Rt, H),
        (Rt, H + rim_h),
        (Rt - lip, H + rim_h),
        (Rt - lip, H + rim_h - recess),
        (0.0, H + rim_h - recess),
    ]
    return finish([revolve_z(prof)])


def make_plate(rng: np.random.Generator) -> trimesh.Trimesh:
    """Plate (symmetric about z): varies the well radius, rim slope and width, thickness and
    the foot ring."""
    R = 1.0
    Rw = R * rng.uniform(0.45, 0.8)
    slope = np.deg2rad(rng.uniform(6.0, 35.0))
    rise = (R - Rw) * libm.tan(slope)
    t = rng.uniform(0.02, 0.05)
    prof: list[tuple[float, float]] = []
    if rng.random() < 0.6:
        Rf, fh = Rw * rng.uniform(0.7, 0.95), rng.uniform(0.02, 0.05)
        prof += [(0.0, 0.0), (Rf, 0.0), (Rf, fh)]
        base = fh
    else:
        base = 0.0
        prof += [(0.0, 0.0)]
    prof += [
        (Rw, base),
        (R, base + rise),
        (R, base + rise + t),
        (Rw - t * libm.tan(slope / 2), base + t),
        (0.0, base + t),
    ]
    return finish([revolve_z(prof, sections=64)])
