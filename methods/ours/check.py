"""Occlusion-aware verification of poses against the depth image (ours' ``selection.rule=depth``).

A pose hypothesis ``T_template_camera`` is checked the way the BOP-era point-pair methods verify
theirs (Vidal, Lin, Martí 2018; Hinterstoisser et al. 2016) and the way BOP's VSD reads depth:
render the template at that pose into the camera and compare, pixel by pixel, the rendered depth
``r`` with the observed depth ``o`` of the scene (:class:`~catpose.types.DepthImage`):

- a pixel of the object's mask costs ``min(|r - o|, tau) / tau``, and 1 where the rendering
  leaves it empty (the pose does not explain what was segmented);
- a pixel outside the mask where the rendering lies in front of the observation by more than
  ``tau`` costs ``free_weight`` (the pose puts surface into space the sensor saw through);
- rendered surface behind the observation outside the mask costs nothing: something else hides
  it, which is what clutter does; pixels without a measurement cost nothing either.

The score is the summed cost divided by the mask's pixel count (lower is better; 0 = every mask
pixel explained within noise and no free space violated). Unlike the visibility-aware Chamfer
(:func:`catpose.methods.pose_scores.visibility_chamfer`), a side of the template that another
object hides is not held against the pose.

Cost is kept small by scoring on a lattice of pixels (every ``stride``-th row and column, the
stride chosen so that the mask has about ``target_pixels`` lattice pixels and a hypothesis'
window at most ``max_rays``), casting only the rays of each hypothesis' window (the projection of
the template's bounding sphere) that can change its cost, all hypotheses in one call of one cached
ray-casting scene per template (:class:`catpose.raycast.RayCaster`: Open3D ``RaycastingScene``,
hits recomputed in float64), each window's costs in one compiled call (:mod:`catpose.methods.ours.check_kernel`). Lengths are in the unit of the depth image and the template (object-normalised).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from catpose.content_hash import template_hash
from catpose.lru import LRUCache
from catpose.methods.ours import span
from catpose.methods.ours.check_kernel import needed, window_cost, window_fit
from catpose.methods.ours.settings import SelectionSettings
from catpose.raycast import RayCaster
from catpose.types import DepthImage, RegistrationProblem, Template

__all__ = ["DEPTH_MAX_RAYS", "DEPTH_PIXELS", "DepthVerifier", "caster_for", "depth_verifier", "final_verifier"]

#: lattice pixels wanted in the object's mask for ours' check of many poses (the pool, the
#: resting-pose search); at most DEPTH_MAX_RAYS rays a pose (a coarser lattice otherwise). Chosen
#: with the coarse search on the clutter dev scenes (docs/choosing-defaults.md): more pixels cost
#: time and changed no answer there.
DEPTH_PIXELS = 300
DEPTH_MAX_RAYS = 2500

_CASTERS: LRUCache[str, tuple[RayCaster, float]] = LRUCache(16)
#: renderings a verifier keeps, keyed by the pose's bytes (the newest): the search's poses are not cast again
RENDERS_KEPT = 128


def caster_for(template: Template) -> tuple[RayCaster, float]:
    """The template mesh's ray-casting scene and its bounding radius (largest vertex distance
    from the template origin), cached per mesh content. The template must have a mesh."""
    key = template.template_id + "-" + template_hash(template, "vertices", "triangles")
    hit = _CASTERS.get(key)
    if hit is None:
        v = np.asarray(template.vertices, dtype=np.float64)
        hit = (RayCaster(v, template.triangles), float(np.sqrt((v * v).sum(axis=1)).max()))
        _CASTERS.put(key, hit)
    return hit


@dataclass(frozen=True)
class _Lattice:
    """The scored pixels: every ``stride``-th row and column of the image."""

    stride: int
    rows: np.ndarray  # (Hs,) image rows of the lattice
    cols: np.ndarray  # (Ws,) image columns
    depth: np.ndarray  # (Hs, Ws) observed depth
    mask: np.ndarray  # (Hs, Ws) object mask
    dirs: np.ndarray  # (Hs, Ws, 3) camera-frame rays with z = 1


class DepthVerifier:
    """Scores poses of one template against one depth image (see the module docstring).

    Args:
        template: the template, with a mesh (``vertices``, ``triangles``).
        image: the problem's depth image (depth in the template's unit), intrinsics and mask.
        tau: depth tolerance (object-normalised unit): agreement within it is (nearly) free,
            a rendered surface further than it in front of the observation violates free space.
        target_pixels: lattice pixels wanted inside the mask.
        max_rays: at most this many lattice pixels in one hypothesis' window (coarser lattice).
        free_weight: cost of one free-space violation relative to one unexplained mask pixel.
    """

    def __init__(
        self,
        template: Template,
        image: DepthImage,
        tau: float = 0.1,
        target_pixels: int = 300,
        max_rays: int = 2500,
        free_weight: float = 1.0,
    ) -> None:
        self.caster, self.radius = caster_for(template)
        self.image = image
        self.tau = float(tau)
        self.free_weight = float(free_weight)
        K = image.K
        self.fx, self.fy, self.cx, self.cy = float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])
        n_mask = int(image.mask.sum())
        if n_mask == 0:
            raise ValueError("DepthVerifier: the depth image's mask is empty")
        # the stride: about target_pixels in the mask, and a window (the template's projected
        # bounding sphere at the mask's median depth) of at most max_rays lattice pixels
        z = float(np.median(image.depth[image.mask]))
        window_px = 2.0 * max(self.fx, self.fy) * self.radius / max(z - self.radius, 0.25 * z)
        stride = max(1.0, np.sqrt(n_mask / max(target_pixels, 1)), window_px / np.sqrt(max(max_rays, 1)))
        self.lattice = self._lattice(int(np.ceil(stride)))
        self._renders: dict[tuple, tuple] = {}  # (pose's bytes, tolerance) -> (window, rendering)
        lo, hi = self.caster.bounds  # grown far beyond float32's rounding of hits (the pruning's margin)
        self.box = (lo - 1e-3 * self.radius, hi + 1e-3 * self.radius)
        self._inner: dict[int, np.ndarray] = {}  # the lattice's inner mask per erosion (fits)
        self.span_depth = span.median_depth(image)  # the object's depth span's centre

    def _lattice(self, stride: int) -> _Lattice:
        h, w = self.image.depth.shape
        rows, cols = np.arange(0, h, stride), np.arange(0, w, stride)
        rr, cc = np.meshgrid(rows, cols, indexing="ij")
        dirs = np.stack([(cc - self.cx) / self.fx, (rr - self.cy) / self.fy, np.ones(rr.shape)], axis=-1)
        return _Lattice(
            stride, rows, cols, self.image.depth[np.ix_(rows, cols)], self.image.mask[np.ix_(rows, cols)], dirs
        )

    @property
    def mask_pixels(self) -> int:
        """Lattice pixels in the mask (the score's denominator)."""
        return int(self.lattice.mask.sum())

    def windows(self, T_template_camera: np.ndarray) -> list[tuple[slice, slice] | None]:
        """Per pose, the lattice window (row slice, column slice) that the template's bounding
        sphere projects into; None when the template is not in front of the camera."""
        L, T = self.lattice, np.asarray(T_template_camera, dtype=np.float64).reshape(-1, 4, 4)
        c = -np.matmul(T[:, :3, :3].transpose(0, 2, 1), T[:, :3, 3, None])[:, :, 0]  # template origins, camera frame
        x, y, z, rad = c[:, 0], c[:, 1], c[:, 2], self.radius
        with np.errstate(divide="ignore", invalid="ignore"):  # behind the camera: no window anyway
            u, v = self.fx * x / z + self.cx, self.fy * y / z + self.cy
            ru, rv = self.fx * rad / (z - rad) + 1.0, self.fy * rad / (z - rad) + 1.0
        r0, r1 = np.searchsorted(L.rows, v - rv), np.searchsorted(L.rows, v + rv, side="right")
        c0, c1 = np.searchsorted(L.cols, u - ru), np.searchsorted(L.cols, u + ru, side="right")
        ok = (z > 1.05 * rad) & (r1 > r0) & (c1 > c0)
        bounds = zip(ok.tolist(), r0.tolist(), r1.tolist(), c0.tolist(), c1.tolist())
        return [(slice(i, j), slice(k, m)) if o else None for o, i, j, k, m in bounds]

    def render(
        self, T_template_camera: np.ndarray, tolerance: float | None = None
    ) -> list[tuple[tuple[slice, slice] | None, np.ndarray]]:
        """Per pose, its window and the rendered depth (window-shaped, 0 where the template is
        not hit), the poses not rendered lately cast in one call (the last ``RENDERS_KEPT``
        renderings are kept: a pose scored and then measured by :meth:`fit` is cast once). With
        a ``tolerance``, only the pixels whose rendering can change a cost or fit of that
        tolerance are cast (:func:`~catpose.methods.ours.check_kernel.needed`); the others read 0."""
        T_all = np.asarray(T_template_camera, dtype=np.float64).reshape(-1, 4, 4)
        keys = [(T.tobytes(), tolerance) for T in T_all]
        new = [i for i, k in enumerate(keys) if k not in self._renders]
        cast = dict(zip(new, self._cast(T_all[new], tolerance))) if new else {}
        out = [cast[i] if i in cast else self._renders[k] for i, k in enumerate(keys)]
        for i in new[-RENDERS_KEPT:]:
            self._renders[keys[i]] = cast[i]
        while len(self._renders) > RENDERS_KEPT:
            del self._renders[next(iter(self._renders))]  # the oldest first
        return out

    def _cast(self, T_all: np.ndarray, tolerance: float | None) -> list[tuple[tuple[slice, slice] | None, np.ndarray]]:
        """:meth:`render` of poses (B, 4, 4), all cast in one call."""
        L, wins = self.lattice, self.windows(T_all)
        dirs, needs, origins = [], [], []
        for T, win in zip(T_all, wins):
            if win is not None:
                d = L.dirs[win].reshape(-1, 3) @ T[:3, :3].T  # ray directions in the template frame
                o, m, t = L.depth[win], L.mask[win], T[:3, 3]
                full = (np.ones(len(d), bool), d)
                need, rays = full if tolerance is None else needed(o, m, d, t, *self.box, tolerance)
                needs.append(need)
                dirs.append(rays)
                origins.append(t)  # the camera centre in the template frame
        if not needs:
            return [(None, np.zeros(0))] * len(wins)
        s = self.caster.cast(np.repeat(origins, [len(d) for d in dirs], axis=0), np.concatenate(dirs))
        r = np.zeros(sum(map(len, needs)))
        r[np.concatenate(needs)] = np.where(np.isfinite(s) & (s > 0), s, 0.0)
        out, k = [], 0
        for win in wins:
            shape = (0,) if win is None else L.depth[win].shape
            out.append((win, r[k : k + math.prod(shape)].reshape(shape)))
            k += math.prod(shape)
        return out

    def scores(self, T_template_camera: np.ndarray) -> np.ndarray:
        """(B,) occlusion-aware depth costs of the poses (lower is better; see the module doc)."""
        L = self.lattice
        mask_pixels = self.mask_pixels
        n_mask = max(mask_pixels, 1)
        out = []
        for win, r in self.render(T_template_camera, self.tau):
            if win is None:
                out.append(np.inf)
                continue
            costs, free = window_cost(L.depth[win], L.mask[win], r, self.tau)
            mask_cost = costs.sum() + (mask_pixels - len(costs))  # mask pixels outside the window: unexplained
            out.append((mask_cost + self.free_weight * free) / n_mask)
        return np.asarray(out, dtype=np.float64)

    def fit(self, T_template_camera: np.ndarray, tolerance: float | None = None, erode_px: int = 0) -> np.ndarray:
        """(B, 2) per pose: the fraction of mask pixels explained within ``tolerance`` (default
        ``tau``) and the free-space violations (by more than ``tolerance``) per mask pixel: how
        well a pose fits, in units that do not depend on the object's size. With ``erode_px`` > 0
        the explained fraction counts only the mask pixels at least that many image pixels inside
        the mask's edge (the whole mask where none are) and within the object's depth span
        (:mod:`~catpose.methods.ours.span`; all of them where none is)."""
        L = self.lattice
        tol = self.tau if tolerance is None else float(tolerance)
        inner = self._inner_mask(int(erode_px)) if erode_px > 0 else L.mask
        n_mask = max(int(inner.sum()), 1)
        out = np.zeros((len(np.asarray(T_template_camera).reshape(-1, 4, 4)), 2))
        for b, (win, r) in enumerate(self.render(T_template_camera, min(tol, self.tau))):  # scores' rendering serves it
            if win is not None:
                inliers, free = window_fit(L.depth[win], L.mask[win], inner[win], r, tol)
                out[b] = (inliers / n_mask, free / n_mask)
        return out

    def _inner_mask(self, erode_px: int) -> np.ndarray:
        """The lattice's mask pixels at least ``erode_px`` image pixels inside the mask's edge
        (the whole lattice mask where erosion leaves none), of them those within the object's depth
        span (all where none is)."""
        from scipy.ndimage import binary_erosion

        hit = self._inner.get(erode_px)
        if hit is None:
            L, mask = self.lattice, self.image.mask
            rows, cols = np.nonzero(mask.any(axis=1))[0], np.nonzero(mask.any(axis=0))[0]
            # the mask's box grown by the erosion's reach: outside it nothing erodes differently
            r0, r1 = max(rows[0] - erode_px - 1, 0), min(rows[-1] + erode_px + 2, mask.shape[0])
            c0, c1 = max(cols[0] - erode_px - 1, 0), min(cols[-1] + erode_px + 2, mask.shape[1])
            eroded = np.zeros_like(mask)
            eroded[r0:r1, c0:c1] = binary_erosion(mask[r0:r1, c0:c1], iterations=erode_px)
            inner = eroded[np.ix_(L.rows, L.cols)]
            inner = inner if inner.any() else L.mask
            kept = inner & span.in_span(L.depth, self.span_depth)
            hit = self._inner[erode_px] = kept if kept.any() else inner
        return hit


def depth_verifier(sel: SelectionSettings, problem: RegistrationProblem, pixels: int = DEPTH_PIXELS) -> DepthVerifier:
    """Ours' depth check of ``problem``'s template against its depth image on a lattice of about
    ``pixels`` mask pixels (the coarse one, :data:`DEPTH_PIXELS`, by default; as many rays a pixel
    as it), with ``sel``'s tolerance and free-space weight."""
    rays = DEPTH_MAX_RAYS * pixels // DEPTH_PIXELS
    return DepthVerifier(problem.template, problem.depth_image, sel.depth_tau, pixels, rays, sel.depth_free_weight)


def final_verifier(
    sel: SelectionSettings, problem: RegistrationProblem, verifier: DepthVerifier | None = None
) -> DepthVerifier:
    """The depth check of ours' final comparison: on a finer lattice when ``sel.depth_final_pixels``
    exceeds :data:`DEPTH_PIXELS`, else ``verifier`` (the problem's :func:`depth_verifier`)."""
    if sel.depth_final_pixels > DEPTH_PIXELS:
        return depth_verifier(sel, problem, sel.depth_final_pixels)
    return depth_verifier(sel, problem) if verifier is None else verifier
