"""``catpose.register``: one call from an observed cloud and a template to a camera pose.

The application layer. This is the one module under ``src/catpose`` that imports
``catpose.methods``, ``catpose.bench`` (the builder that turns ``configs/method/<name>.yaml``
into a method, exactly as ``bench run`` does) and ``catpose.datasets`` (mesh reading, surface
sampling, normal estimation); every other module under ``src/catpose`` stays below those
packages. ``import catpose`` does not load it: ``catpose.register`` imports it on first use.

Units and frames. The caller's two clouds share one unit (mm, m, ...). The methods work in the
object-normalised unit (the template centred at its bounding-box centre ``c`` and divided by
its radius ``s``, the distance of its farthest point from ``c``), so the template becomes
``(R_up p - c) / s`` (``R_up`` turns the caller's ``template_up`` onto +z, the methods' up
axis) and the observation ``p / s`` (camera frame, origin kept: ours scores visibility from
the camera). A method's answer ``T_n`` maps back to the caller's frames and units as
``R = R_up^T R_n``, ``t = R_up^T (s t_n + c)``.

Example::

    import catpose
    result = catpose.register(points_mm, "mug.ply", up=[0.0, -0.8, -0.6])
    print(result.T_template_camera)   # (4, 4), millimetres: p_template = R p_camera + t
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from catpose.errors import CatposeError, InvalidInputError
from catpose.geometry import apply_R, axis_angle_to_R, dot3, make_T, matmul3, norm3, normalize_to_unit_sphere, unit3
from catpose.lru import LRUCache
from catpose.types import RegistrationProblem, RegistrationResult, Template

__all__ = ["Registration", "register", "build_method", "UP_HYPOTHESES"]

#: Up directions tried (a Fibonacci sphere in the camera frame) when ``up`` is not given and the
#: method needs one (ours; a correspondence baseline with LPS features). Measured on the synthetic
#: set by ``results/api/make_without_up.sh`` (``results/api/without_up.md``).
UP_HYPOTHESES = 24

#: Methods built from configs, reused across calls (their template caches with them).
_METHODS: LRUCache[tuple, Any] = LRUCache(4)


@dataclass(frozen=True, eq=False)
class Registration:
    """What :func:`register` returns; lengths in the caller's unit.

    Attributes:
        T_template_camera: (4, 4) estimated pose, ``p_template = R p_camera + t``, in the
            caller's template frame and unit.
        score: the method's own final score of that pose (lower is better): ours and the
            correspondence baselines a distance in the object-normalised unit (times ``scale``
            for the caller's unit), ICP ``1 - fitness``.
        candidates: (K, 4, 4) every hypothesis the method scored before choosing, as
            ``T_template_camera`` in the caller's frame and unit (ours: one per partial template,
            before its final refinement; ICP: one per start). With ``up=None`` and a method that
            needs gravity, the candidates of every up hypothesis, concatenated.
        candidate_scores: (K,) their scores (lower is better, inf: excluded by the method).
        method: the method's config name (or class name for an instance).
        scale: the template radius in the caller's unit (one object-normalised unit).
        up_camera: (3,) the up direction used, camera frame (given, or the best hypothesis of
            the search), or None when the method does not use one.
        extras: the method's extras (timings, chosen template index, ...) and, after an up
            search, ``up_search`` (hypotheses and their scores).
        runtime_s: wall-clock seconds of the method call(s), normalisation excluded.
    """

    T_template_camera: np.ndarray
    score: float
    candidates: np.ndarray
    candidate_scores: np.ndarray
    method: str
    scale: float
    up_camera: np.ndarray | None
    extras: Mapping[str, Any] = field(default_factory=dict)
    runtime_s: float = float("nan")


# --------------------------------------------------------------------------- inputs

def _cloud(name: str, value: Any, min_points: int = 10) -> np.ndarray:
    """An (N, 3) float64 array from ``value``, or a one-line error naming the argument."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} is a {type(value).__name__}, not an (N, 3) array of numbers") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise InvalidInputError(f"{name} has shape {a.shape}; expected (N, 3)")
    if not np.isfinite(a).all():
        raise InvalidInputError(f"{name} has {int((~np.isfinite(a).all(axis=1)).sum())} rows with NaN or inf; "
                                "drop them first")
    if len(a) < min_points:
        raise InvalidInputError(f"{name} has {len(a)} points; at least {min_points} are needed")
    return a


def _normals(name: str, value: Any, points: np.ndarray) -> np.ndarray | None:
    if value is None:
        return None
    n = _cloud(name, value, min_points=0)
    if n.shape != points.shape:
        raise InvalidInputError(f"{name} has shape {n.shape}; expected {points.shape} (one normal per point)")
    length = norm3(n)
    if (length < 1e-12).any():
        raise InvalidInputError(f"{name} has {int((length < 1e-12).sum())} zero-length normals; pass None to estimate them")
    return n / length[:, None]


def _direction(name: str, value: Any) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r} is not a 3-vector of numbers") from None
    if v.shape != (3,) or not np.isfinite(v).all() or norm3(v) < 1e-12:
        raise InvalidInputError(f"{name}={value!r} is not a finite non-zero 3-vector")
    return unit3(v)


def _template_geometry(template: Any) -> tuple[np.ndarray, np.ndarray | None]:
    """``(points or vertices (M, 3), triangles (F, 3) or None)`` of any accepted template form."""
    if isinstance(template, (str, Path)):
        from catpose.datasets.meshio import read_mesh

        if not Path(template).is_file():
            raise InvalidInputError(f"template: mesh file {template} does not exist; pass an existing .off, .obj or "
                                    ".ply file, a mesh or an (M, 3) array")
        try:
            return read_mesh(template)
        except CatposeError as e:
            raise InvalidInputError(f"template: {e}") from None
    if hasattr(template, "vertices") and hasattr(template, "faces"):  # a trimesh.Trimesh (or alike)
        v, f = np.asarray(template.vertices), np.asarray(template.faces)
        if f.size == 0:
            return _cloud("template vertices", v), None
        return _cloud("template vertices", v, 3), _triangles(f, len(v))
    if isinstance(template, (tuple, list)) and len(template) == 2 and np.ndim(template[1]) == 2 \
            and np.shape(template[1])[-1] == 3 and np.ndim(template[0]) == 2:
        v = _cloud("template vertices", template[0], 3)
        return v, _triangles(template[1], len(v))
    return _cloud("template", template), None


def _triangles(faces: Any, n_vertices: int) -> np.ndarray:
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer):
        raise InvalidInputError(f"template faces have shape {f.shape} and dtype {f.dtype}; expected (F, 3) integers")
    if f.min() < 0 or f.max() >= n_vertices:
        raise InvalidInputError(f"template faces index vertices outside 0..{n_vertices - 1}")
    return f.astype(np.int64)


def _R_onto_z(up: np.ndarray) -> np.ndarray:
    """The shortest-arc rotation (3, 3) taking unit ``up`` onto +z."""
    from catpose import libm

    z = np.array([0.0, 0.0, 1.0])
    c = float(np.clip(dot3(up, z), -1.0, 1.0))
    if c > 1.0 - 1e-12:
        return np.eye(3)
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])  # a half turn about x
    return axis_angle_to_R(np.cross(up, z), float(libm.arccos(c)))


def _subsample(n: int, max_points: int, key: str) -> np.ndarray | None:
    """Sorted indices of a seeded random subset of ``max_points`` of ``n`` (None: keep all)."""
    if not max_points or n <= max_points:
        return None
    from catpose.geometry import stable_seed

    return np.sort(np.random.default_rng(stable_seed("catpose.register", key)).choice(n, max_points, replace=False))


def _make_template(template: Any, template_normals: Any, template_up: np.ndarray,
                   template_points: int) -> tuple[Template, np.ndarray, np.ndarray, float]:
    """The normalised :class:`Template` and ``(R_up (3, 3), centre (3,), scale)`` with
    ``p_normalised = (R_up p - centre) / scale``."""
    from catpose.datasets.meshio import sampled_template
    from catpose.datasets.render import estimate_normals

    geometry, triangles = _template_geometry(template)
    normals = None if triangles is not None else _normals("template_normals", template_normals, geometry)
    if triangles is not None and template_normals is not None:
        raise InvalidInputError("template_normals applies to a point-cloud template; a mesh's normals come "
                                "from its faces: drop template_normals")
    R_up = _R_onto_z(template_up)
    rotated = apply_R(R_up, geometry)
    try:
        points, centre, scale = normalize_to_unit_sphere(rotated)
    except ValueError:
        raise InvalidInputError("template has zero extent (all points equal)") from None
    extent = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if extent[1] <= 1e-9 * np.sqrt(len(points)):
        raise InvalidInputError("template is degenerate: all points lie on one line")
    if triangles is not None:
        try:
            t = sampled_template(points, triangles, "catpose.register/template", "object", template_points)
        except CatposeError as e:
            raise InvalidInputError(f"template: {e}") from None
        return t, R_up, centre, scale
    if normals is None:  # as the datasets do: local planes, radius 0.1 object unit, here oriented outwards
        normals = estimate_normals(points, 0.1, viewpoint=np.zeros(3))
        normals = -normals  # estimate_normals faces the viewpoint (the centre): outwards is the opposite
    else:
        normals = apply_R(R_up, normals)
    keep = _subsample(len(points), template_points, "template")
    if keep is not None:
        points, normals = points[keep], normals[keep]
    try:
        t = Template(template_id="catpose.register/template", category="object", points=points, normals=normals)
    except CatposeError as e:
        raise InvalidInputError(f"template: {e}") from None
    return t, R_up, centre, scale


# --------------------------------------------------------------------------- methods

def _override_value(value: Any) -> str:
    """A Python value as Hydra override syntax (``None`` -> ``null``, strings quoted)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(float(value)) if isinstance(value, (float, np.floating)) else str(int(value))
    if isinstance(value, str):
        return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_override_value(v) for v in value) + "]"
    raise InvalidInputError(f"option value {value!r} ({type(value).__name__}) is not a number, string, bool, "
                            "None or list")


def _overrides(options: Mapping[str, Any], prefix: str = "method") -> list[str]:
    """``{"selection": {"gravity_max_deg": None}, "descriptor": "pfh"}`` -> Hydra overrides:
    nested dicts become dotted keys; a string naming a config of the group ``configs/<key>/``
    (``descriptor="pfh"``) selects that config, as ``descriptor@method.descriptor=pfh`` does."""
    from importlib import resources

    out = []
    for key, value in options.items():
        if isinstance(value, Mapping):
            out += _overrides(value, f"{prefix}.{key}")
            continue
        group = resources.files("catpose.configs") / str(key)
        if prefix == "method" and isinstance(value, str) and (group / f"{value}.yaml").is_file():
            out.append(f"{key}@method.{key}={value}")
        else:
            out.append(f"{prefix}.{key}={_override_value(value)}")
    return out


def build_method(name: str, **options: Any) -> Any:
    """The method ``configs/method/<name>.yaml`` with ``options`` as overrides, built by the same
    builder as ``bench run`` (cached: the same name and options give the same object, whose
    template caches then serve later calls). A one-line :class:`InvalidInputError` names an
    unknown method or option."""
    key = (name, repr(sorted(options.items())))
    hit = _METHODS.get(key)
    if hit is not None:
        return hit
    from hydra import compose, initialize_config_module
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    from catpose.bench.build import build_from_config
    from catpose.bench.run_cmd import available

    names = available("method")
    if name not in names:
        raise InvalidInputError(f"method={name!r} is not a method config; choose one of {', '.join(names)} "
                                "or pass a RegistrationMethod instance")
    overrides = [f"method={name}", *_overrides(options)]
    try:
        with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
            cfg = compose(config_name="run", overrides=overrides)
        built = build_from_config(cfg.method, "method")[1]
    except (HydraException, OmegaConfBaseException) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise InvalidInputError(f"options {sorted(options)} do not fit method {name!r}: {first}") from None
    except CatposeError as e:
        raise InvalidInputError(f"options of method {name!r}: {e}") from None
    _METHODS.put(key, built)
    return built


def _uses_up(method: Any) -> bool:
    """Whether the method reads the ground normal: ours (descriptor frames and gravity filter),
    a correspondence baseline on LPS features; not ICP, FPFH or PFH matching."""
    from catpose.methods.ours import Ours

    if isinstance(method, Ours):
        return True
    return getattr(method, "features", None) == "lps"


# --------------------------------------------------------------------------- register

def register(observation: Any, template: Any, method: str | Any = "ours", up: Sequence[float] | None = None, *,
             observation_normals: Any = None, template_normals: Any = None,
             template_up: Sequence[float] = (0.0, 0.0, 1.0), max_points: int = 2048, template_points: int = 2048,
             up_hypotheses: int = UP_HYPOTHESES, **options: Any) -> Registration:
    """Estimate the camera pose ``T_template_camera`` of a partial view of an object.

    Args:
        observation: (N, 3) observed surface points in the camera frame, any unit (the same as
            the template's); segmented (only the object).
        template: the object or category template in its own frame: an (M, 3) point array, a
            ``trimesh.Trimesh``, a ``(vertices (V, 3), faces (F, 3))`` pair, or the path of an
            OFF, OBJ or PLY mesh. A mesh is sampled on its outer surface (``template_points``).
        method: a config name, ``ours`` (the paper's method), ``icp``, ``fgr``, ``ransac``,
            ``teaser`` (``configs/method/<name>.yaml``, built as ``bench run`` builds it), or a
            :class:`~catpose.methods.base.RegistrationMethod` instance.
        up: the template's up direction (``template_up``) seen in the camera frame, i.e. the
            ground plane's normal pointing away from the ground (3,). ICP and the FPFH/PFH
            baselines do not use it. Ours does (LPS descriptor frames and its gravity filter):
            without it, ours is run once per direction of ``up_hypotheses`` spread over the
            sphere and the best-scoring answer is kept, which costs ``up_hypotheses`` times the
            time and is less accurate (figures: ``results/api/without_up.md``).
        observation_normals: (N, 3) normals of ``observation`` (any orientation: they are turned
            towards the camera), or None to estimate them by local plane fits (radius 0.1
            template radii, as the datasets do).
        template_normals: (M, 3) outward normals of a point-cloud template, or None to estimate
            them (oriented away from the template's bounding-box centre: right for convex-ish
            shapes; pass them for shapes with deep concavities).
        template_up: the template's up axis in its own frame (default +z).
        max_points: the observation keeps at most this many points (seeded random subset, after
            normal estimation; 0 keeps all), as the datasets do.
        template_points: points sampled on a mesh template, or kept of a cloud template.
        up_hypotheses: up directions tried when ``up`` is None and the method needs one.
        **options: method options as in ``bench run`` (``method.<key>=<value>``), e.g.
            ``voxel_size=0.05`` (icp), ``selection={"gravity_max_deg": None}`` or
            ``descriptor="pfh"`` (ours). Ignored when ``method`` is an instance (pass none).

    Returns:
        a :class:`Registration` in the caller's frames and unit.

    Raises:
        InvalidInputError: a bad argument, in one line naming it.

    Deterministic: the same inputs give the same answer (the global NumPy, torch and Open3D
    seeds are set before each method call, as ``bench run`` does per sample).
    """
    pts = _cloud("observation", observation)
    obs_normals = _normals("observation_normals", observation_normals, pts)
    t_up = _direction("template_up", template_up)
    up_camera = None if up is None else _direction("up", up)
    for name, value in (("max_points", max_points), ("template_points", template_points),
                        ("up_hypotheses", up_hypotheses)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < (name == "max_points" and 0 or 1):
            raise InvalidInputError(f"{name}={value!r} is not a positive integer")
    if isinstance(method, str):
        method_name, impl = method, build_method(method, **options)
    else:
        if not callable(getattr(method, "register", None)):
            raise InvalidInputError(f"method is a {type(method).__name__}; pass a config name "
                                    "(ours, icp, fgr, ransac, teaser) or a RegistrationMethod instance")
        if options:
            raise InvalidInputError(f"options {sorted(options)} apply to a method config name, not to an instance; "
                                    "set them on the instance")
        method_name, impl = type(method).__name__, method

    tmpl, R_up, centre, scale = _make_template(template, template_normals, t_up, int(template_points))
    points = pts / scale
    radius = float(norm3(points - 0.5 * (points.min(axis=0) + points.max(axis=0))).max())
    if radius > 2.0:
        warnings.warn(f"catpose.register: the observation spans {radius:.1f} template radii; check that both clouds "
                      "use the same unit and that the observation holds only the object", stacklevel=2)
    normals = _orient_to_camera(points, obs_normals) if obs_normals is not None else _estimate(points)
    keep = _subsample(len(points), int(max_points), "observation")
    if keep is not None:
        points, normals = points[keep], normals[keep]

    needs_up = _uses_up(impl)
    if up_camera is not None or not needs_up:
        # R_up maps template-frame directions into the normalised frame; the camera frame is not rotated
        g = up_camera if up_camera is not None else np.array([0.0, -1.0, 0.0])  # unused by this method
        t0 = time.perf_counter()
        result = _call(impl, _problem(points, normals, g, tmpl))
        runtime = time.perf_counter() - t0
        chosen_up, extras = (up_camera if needs_up or up_camera is not None else None), dict(result.extras)
        cands, scores = _candidates(result)
    else:
        from catpose.datasets.meshio import fibonacci_sphere

        t0 = time.perf_counter()
        tried = []
        for g in fibonacci_sphere(int(up_hypotheses)):
            try:
                tried.append((g, _call(impl, _problem(points, normals, unit3(g), tmpl))))
            except InvalidInputError:
                raise
            except CatposeError:  # a hypothesis without an answer (no correspondences): the others decide
                continue
        runtime = time.perf_counter() - t0
        if not tried:
            raise InvalidInputError("observation: no up hypothesis gave a pose; pass up (the ground normal)")
        best = min(range(len(tried)), key=lambda i: (not np.isfinite(tried[i][1].score), tried[i][1].score))
        chosen_up, result = tried[best]
        extras = dict(result.extras)
        extras["up_search"] = {"hypotheses": [[float(x) for x in g] for g, _ in tried],
                               "scores": [float(r.score) for _, r in tried], "chosen": best}
        parts = [_candidates(r) for _, r in tried]
        cands, scores = np.concatenate([c for c, _ in parts]), np.concatenate([s for _, s in parts])

    to_caller = lambda T: _to_caller(T, R_up, centre, scale)  # noqa: E731
    return Registration(T_template_camera=to_caller(np.asarray(result.T_target_source, float)),
                        score=float(result.score), candidates=np.stack([to_caller(T) for T in cands]),
                        candidate_scores=scores, method=method_name, scale=float(scale),
                        up_camera=None if chosen_up is None else np.asarray(chosen_up, float),
                        extras=extras, runtime_s=runtime)


def _estimate(points: np.ndarray) -> np.ndarray:
    from catpose.datasets.render import estimate_normals

    return estimate_normals(points, 0.1)


def _orient_to_camera(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    flip = dot3(normals, points) > 0  # the camera sits at the origin
    out = normals.copy()
    out[flip] *= -1
    return out


def _problem(points: np.ndarray, normals: np.ndarray, g: np.ndarray, template: Template) -> RegistrationProblem:
    try:
        return RegistrationProblem(sample_id="catpose.register", category="object", points_camera=points,
                                   normals_camera=normals, ground_normal_camera=g, template=template)
    except CatposeError as e:
        raise InvalidInputError(str(e).replace("sample catpose.register: observed cloud", "observation")) from None


def _call(method: Any, problem: RegistrationProblem) -> RegistrationResult:
    """``method.register(problem)`` with the global seeds set as ``bench run`` sets them."""
    from catpose.bench.sample_run import seed_everything

    seed_everything(0)
    return method.register(problem)


def _candidates(result: RegistrationResult) -> tuple[np.ndarray, np.ndarray]:
    if result.candidates_T is None or len(result.candidates_T) == 0:
        return np.asarray(result.T_target_source, float)[None], np.array([float(result.score)])
    return np.asarray(result.candidates_T, float), np.asarray(result.candidate_scores, float)


def _to_caller(T_n: np.ndarray, R_up: np.ndarray, centre: np.ndarray, scale: float) -> np.ndarray:
    """``T_template_camera`` in the caller's frame and unit from the normalised estimate ``T_n``."""
    return make_T(matmul3(R_up.T, T_n[:3, :3]), apply_R(R_up.T, scale * T_n[:3, 3] + centre))
