"""A structured-light / stereo depth-sensor model applied to rendered depth (``dataset.sensor``).

Everything here is in metres: the synthetic set scales each category to a physical size
(:data:`CATEGORY_SIZE_M`) and places the camera at a physical distance before rendering.
:func:`apply_sensor` turns a clean rendered depth image and the object's true mask into what a
real sensor and a real segmentation give, in this order (the observation pipeline is then:
render, noise, subsample, normals):

1. **Lateral noise at edges** (Nguyen et al. 2012, Fig. 6: ``sigma_L [px] = 0.8 + 0.035 theta /
   (pi/2 - theta)``): pixels next to a depth discontinuity take the depth of a neighbour offset by
   a Gaussian pixel displacement, so silhouettes jitter.
2. **Flying pixels** at depth discontinuities: with probability ``flying_pixel_prob`` an edge pixel
   gets a depth between the foreground and the background of its 3x3 neighbourhood.
3. **Axial noise** growing with depth squared and with the incidence angle ``theta`` (Nguyen,
   Izadi, Lovell, "Modeling Kinect sensor noise for improved 3D reconstruction and tracking",
   3DIMPVT 2012, Eq. 3)::

       sigma_z(z, theta) = a + b (z - z0)^2 + c / sqrt(z) * theta^2 / (pi/2 - theta)^2   [m]

   with ``a = 0.0012, b = 0.0019, z0 = 0.4, c = 0.0001`` for the Kinect. Active stereo (Intel
   RealSense D400; Grunnet-Jepsen et al., "Tuning depth cameras for best performance", Intel
   white paper 2019: RMS error ``= z^2 * subpixel / (f * baseline)``) is the same form with
   ``a = z0 = 0`` and ``b = subpixel / (f * baseline)``.
4. **Disparity quantisation**: depth is measured as disparity ``d = f_d * baseline / z`` in steps
   of ``1 / subpixel_steps`` pixel, so depth takes values ``f_d * baseline / (k / subpixel_steps)``.
5. **Dropout at grazing angles**: a pixel is lost with probability rising linearly from 0 at
   ``dropout_start_deg`` to 1 at ``dropout_end_deg`` incidence; depth outside
   ``[near_m, far_m]`` is lost too.
6. **An imperfect mask**: the true object mask dilated by ``mask_bleed_px`` pixels, so it bleeds
   into the background (the table plane behind the object), then restricted to valid depth.

Every random draw comes from the one ``numpy.random.Generator`` passed in, so the output is a
pure function of the inputs and the generator's seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose import libm
from catpose.errors import ConfigError

#: Physical bounding radius (metres) of each synthetic category: the scale of the unit-sphere
#: shape when a sensor is simulated. Household objects at their real size (a mug is about 0.1 m
#: tall and 0.12 m wide with its handle); the airplane and car are desk-sized scale models, and the
#: chair a real chair, so every category stays inside a depth camera's working range.
CATEGORY_SIZE_M: dict[str, float] = {
    "mug": 0.07,
    "can": 0.07,
    "bottle": 0.11,
    "bowl": 0.085,
    "plate": 0.13,
    "airplane": 0.25,
    "car": 0.2,
    "chair": 0.55,
}


@dataclass(frozen=True)
class SensorModel:
    """Parameters of :func:`apply_sensor` (lengths in metres, angles in degrees).

    Attributes:
        name: preset name.
        axial_a, axial_b, axial_z0, axial_c: ``sigma_z = a + b (z - z0)^2 + c / sqrt(z) theta^2 / (pi/2 - theta)^2``.
        lateral_px, lateral_angle: ``sigma_L = lateral_px + lateral_angle * theta / (pi/2 - theta)`` pixels.
        edge_jump_m: a 4-neighbour depth difference above this marks a discontinuity.
        flying_pixel_prob: probability that an edge pixel becomes a flying pixel.
        disparity_focal_px, baseline_m, subpixel_steps: disparity ``f_d b / z`` quantised to
            ``1 / subpixel_steps`` pixel (``subpixel_steps = 0``: no quantisation).
        dropout_start_deg, dropout_end_deg: incidence angles where dropout starts and is certain.
        near_m, far_m: working range; depth outside it is dropped.
        mask_bleed_px: dilation of the object mask into the background, pixels (1 at the default
            320x240, f = 300 px: measured against the real YCB-V frames, where 2 gave twice their
            fraction of points > 10 mm off the object, 0.085 vs 0.033).
        distance_m: (min, max) camera distance from the object centre, drawn uniformly; the
            distance is at least ``2.5`` bounding radii so large objects stay in view.
    """

    name: str
    axial_a: float
    axial_b: float
    axial_z0: float
    axial_c: float
    lateral_px: float
    lateral_angle: float
    edge_jump_m: float
    flying_pixel_prob: float
    disparity_focal_px: float
    baseline_m: float
    subpixel_steps: float
    dropout_start_deg: float
    dropout_end_deg: float
    near_m: float
    far_m: float
    mask_bleed_px: int
    distance_m: tuple[float, float] = (0.7, 1.1)

    def axial_sigma(self, z: np.ndarray, theta: np.ndarray | float = 0.0) -> np.ndarray:
        """Axial noise std (m) at depth ``z`` (m) and incidence angle ``theta`` (radians)."""
        z = np.asarray(z, float)
        theta = np.clip(np.asarray(theta, float), 0.0, np.deg2rad(89.0))
        angle = theta**2 / (np.pi / 2 - theta) ** 2
        return (
            self.axial_a + self.axial_b * (z - self.axial_z0) ** 2 + self.axial_c / np.sqrt(np.maximum(z, 1e-6)) * angle
        )

    def lateral_sigma_px(self, theta: np.ndarray | float = 0.0) -> np.ndarray:
        """Lateral noise std (pixels) at incidence angle ``theta`` (radians)."""
        theta = np.clip(np.asarray(theta, float), 0.0, np.deg2rad(89.0))
        return self.lateral_px + self.lateral_angle * theta / (np.pi / 2 - theta)

    def quantize(self, z: np.ndarray) -> np.ndarray:
        """Depth (m) after disparity quantisation; 0 stays 0."""
        z = np.asarray(z, float)
        if self.subpixel_steps <= 0:
            return z
        fb = self.disparity_focal_px * self.baseline_m
        valid = z > 0
        d = np.where(valid, fb / np.where(valid, z, 1.0), 0.0)
        k = np.round(d * self.subpixel_steps)
        out = np.where(valid & (k > 0), fb * self.subpixel_steps / np.maximum(k, 1), 0.0)
        return out

    def dropout_probability(self, theta: np.ndarray) -> np.ndarray:
        """Probability (0..1) that a pixel seen at incidence ``theta`` (radians) is lost."""
        lo, hi = np.deg2rad(self.dropout_start_deg), np.deg2rad(self.dropout_end_deg)
        return np.clip((np.asarray(theta, float) - lo) / max(hi - lo, 1e-9), 0.0, 1.0)


#: Kinect v1 (structured light): Nguyen et al. 2012 noise, 580 px disparity focal length,
#: 7.5 cm baseline, 1/8-pixel disparity steps (2.9 mm at 1 m).
KINECT = SensorModel(
    name="kinect",
    axial_a=0.0012,
    axial_b=0.0019,
    axial_z0=0.4,
    axial_c=0.0001,
    lateral_px=0.8,
    lateral_angle=0.035,
    edge_jump_m=0.02,
    flying_pixel_prob=0.3,
    disparity_focal_px=580.0,
    baseline_m=0.075,
    subpixel_steps=8.0,
    dropout_start_deg=70.0,
    dropout_end_deg=88.0,
    near_m=0.4,
    far_m=4.0,
    mask_bleed_px=1,
)
#: RealSense D435 (active stereo): 0.08 px subpixel RMS, ~430 px focal length at 848x480, 5 cm
#: baseline (RMS 3.7 mm at 1 m), 1/32-pixel disparity steps, 0.2 m minimum range.
REALSENSE = SensorModel(
    name="realsense",
    axial_a=0.0,
    axial_b=0.08 / (430.0 * 0.05),
    axial_z0=0.0,
    axial_c=0.0001,
    lateral_px=1.0,
    lateral_angle=0.035,
    edge_jump_m=0.02,
    flying_pixel_prob=0.5,
    disparity_focal_px=430.0,
    baseline_m=0.05,
    subpixel_steps=32.0,
    dropout_start_deg=65.0,
    dropout_end_deg=85.0,
    near_m=0.2,
    far_m=4.0,
    mask_bleed_px=1,
)

PRESETS: dict[str, SensorModel] = {"kinect": KINECT, "realsense": REALSENSE}


def get_sensor(name: str | None) -> SensorModel | None:
    """The preset called ``name`` (``none`` or None: no sensor model)."""
    if name is None or str(name).lower() == "none":
        return None
    if name not in PRESETS:
        raise ConfigError(f"dataset.sensor={name!r} is unknown; use one of {['none', *PRESETS]}")
    return PRESETS[name]


def incidence_angle(depth: np.ndarray, fx: float, fy: float, cx: float, cy: float) -> np.ndarray:
    """Angle (radians) between each pixel's viewing ray and its surface normal, from the depth
    image's back-projected gradients; ``pi/2`` where the depth or a neighbour is missing.

    Args:
        depth: (H, W) depth in metres, 0 = none.
        fx, fy, cx, cy: pinhole intrinsics, pixels.
    """
    h, w = depth.shape
    v, u = np.mgrid[0:h, 0:w].astype(float)
    P = np.stack([(u - cx) * depth / fx, (v - cy) * depth / fy, depth], axis=-1)
    dPu = np.zeros_like(P)
    dPv = np.zeros_like(P)
    dPu[:, 1:-1] = P[:, 2:] - P[:, :-2]
    dPv[1:-1] = P[2:] - P[:-2]
    n = np.cross(dPu, dPv)
    nn = np.linalg.norm(n, axis=-1)
    ray = P / np.maximum(np.linalg.norm(P, axis=-1, keepdims=True), 1e-12)
    cos = np.abs(np.einsum("hwi,hwi->hw", n, ray)) / np.maximum(nn, 1e-18)
    theta = libm.arccos(np.clip(cos, 0.0, 1.0))  # NumPy's arccos rounds per CPU
    valid = depth > 0
    ok = valid.copy()
    ok[:, 1:-1] &= valid[:, 2:] & valid[:, :-2]
    ok[1:-1] &= valid[2:] & valid[:-2]
    ok[:, [0, -1]] = False
    ok[[0, -1]] = False
    ok &= nn > 0
    return np.where(ok, theta, np.pi / 2)


def discontinuities(depth: np.ndarray, jump_m: float) -> np.ndarray:
    """(H, W) bool: pixels with a 4-neighbour whose depth differs by more than ``jump_m`` (a
    missing neighbour next to a valid pixel counts as a discontinuity)."""
    edge = np.zeros(depth.shape, bool)
    for axis in (0, 1):
        a = np.swapaxes(depth, 0, axis)
        jump = np.abs(a[1:] - a[:-1]) > jump_m
        e = np.swapaxes(edge, 0, axis)
        e[1:] |= jump
        e[:-1] |= jump
    return edge & (depth > 0) | _valid_next_to_invalid(depth)


def _valid_next_to_invalid(depth: np.ndarray) -> np.ndarray:
    from scipy.ndimage import binary_dilation

    invalid = depth <= 0
    return binary_dilation(invalid) & ~invalid


def apply_sensor(
    depth: np.ndarray,
    object_mask: np.ndarray,
    fx: float,
    fy: float,
    cx: float,
    cy: float,
    sensor: SensorModel,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Clean rendered depth and true mask -> sensor depth and segmentation mask.

    Args:
        depth: (H, W) clean depth, metres (camera-frame z), 0 where nothing was hit.
        object_mask: (H, W) bool, pixels where the object is the first surface hit.
        fx, fy, cx, cy: pinhole intrinsics of the image, pixels.
        sensor: the sensor parameters.
        rng: the only source of randomness.

    Returns:
        (H, W) float64 noisy depth in metres (0 = no measurement) and the (H, W) bool observed
        object mask (true mask dilated by ``mask_bleed_px``, restricted to valid depth).
    """
    from scipy.ndimage import binary_dilation, maximum_filter, minimum_filter

    clean = np.asarray(depth, float)
    h, w = clean.shape
    theta = incidence_angle(clean, fx, fy, cx, cy)
    valid = clean > 0
    out = clean.copy()

    # 1-2: lateral noise and flying pixels next to depth discontinuities
    edge = discontinuities(clean, sensor.edge_jump_m)
    near_edge = binary_dilation(edge, iterations=1)
    rows, cols = np.nonzero(near_edge)
    sig = sensor.lateral_sigma_px(np.where(theta[rows, cols] < np.pi / 2, theta[rows, cols], 0.0))
    dr = np.rint(rng.normal(size=len(rows)) * sig).astype(int)
    dc = np.rint(rng.normal(size=len(rows)) * sig).astype(int)
    out[rows, cols] = clean[np.clip(rows + dr, 0, h - 1), np.clip(cols + dc, 0, w - 1)]
    masked = np.where(valid, clean, np.inf)
    fg = minimum_filter(masked, size=3)
    bg = maximum_filter(np.where(valid, clean, 0.0), size=3)
    fly = edge & valid & (rng.random(clean.shape) < sensor.flying_pixel_prob) & np.isfinite(fg)
    u = rng.random(clean.shape)
    out[fly] = fg[fly] + u[fly] * (bg[fly] - fg[fly])

    # 3: axial noise, 4: disparity quantisation
    ok = out > 0
    theta_n = np.where(theta < np.pi / 2, theta, 0.0)
    noise = rng.normal(size=clean.shape) * sensor.axial_sigma(np.where(ok, out, 1.0), theta_n)
    out = np.where(ok, out + noise, 0.0)
    out = sensor.quantize(np.maximum(out, 0.0))

    # 5: dropout at grazing angles and outside the working range
    drop = rng.random(clean.shape) < sensor.dropout_probability(theta)
    drop |= (out < sensor.near_m) | (out > sensor.far_m)
    out[drop] = 0.0

    # 6: the segmentation bleeds into the background
    mask = np.asarray(object_mask, bool)
    if sensor.mask_bleed_px > 0:
        mask = binary_dilation(mask, iterations=int(sensor.mask_bleed_px))
    return out, mask & (out > 0)


def table_mesh(z_object: float, half_size: float = 5.0) -> tuple[np.ndarray, np.ndarray]:
    """A square support plane ``z = z_object`` (object frame, any unit), two triangles facing +z."""
    s = float(half_size)
    v = np.array([[-s, -s, z_object], [s, -s, z_object], [s, s, z_object], [-s, s, z_object]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]], np.int64)
    return v, f
