"""The ``relative`` protocol: the relative camera pose between two views of one object.

This is the paper's real-data protocol (Section IV-C): the absolute object frame of a real scan
is unknown, so each view is registered to a template on its own and the two estimates are
compared through the relative pose they imply:

    T_c1_c2_est = inv(T_template_c1_est) @ T_template_c2_est
    T_c1_c2_gt  = inv(T_object_c1_gt)    @ T_object_c2_gt

The ground truth only has to be consistent between the views of one instance (a Redwood
trajectory frame is enough: ``Observation.info["absolute_gt"]`` may be False).

The per-sample rows (``samples.jsonl``) are the single-view registrations; ``score_units`` turns
them into one row per view pair. A pair's ``err_deg`` is the geodesic angle between the
estimated and true relative rotation, or for rotationally symmetric objects the main-axis error:
the axis as seen in camera 2, mapped into camera 1 by the estimated and by the true relative pose
(this is invariant to each view's unobservable spin about the axis). A failed view fails its
pairs (180 degrees).
"""

from __future__ import annotations

import numpy as np

from catpose.bench.protocols.absolute import GtModel, Protocol, Templates, is_excluded_view, require_consistent_frames
from catpose.bench.scoring.metrics import FAILED_ERROR_DEG, axis_error_deg, rotation_error_deg, translation_error
from catpose.bench.scoring.rows import failed_row, row_array, scored_row
from catpose.datasets.dataset import ObjectDataset
from catpose.errors import ConfigError
from catpose.geometry import invert_T
from catpose.methods.choice_rules import DEFAULT_RULE, ChoiceRule
from catpose.types import Sample

TEMPLATE_SOURCES = ("own", "category")
PAIRINGS = ("consecutive", "all")


def pair_indices(n_views: int, pairs: str, max_pairs: int | None) -> list[tuple[int, int]]:
    """Index pairs ``(i, j)``, ``i < j``, among ``n_views`` ordered views.

    ``pairs="consecutive"`` gives (0, 1), (1, 2), ...; ``"all"`` gives every ``i < j``. When
    ``max_pairs`` is set and smaller, that many pairs are kept, evenly spaced over the list
    (deterministic, so every method is scored on the same pairs).
    """
    if pairs == "consecutive":
        out = [(i, i + 1) for i in range(n_views - 1)]
    elif pairs == "all":
        out = [(i, j) for i in range(n_views) for j in range(i + 1, n_views)]
    else:
        raise ConfigError(f"protocol.pairs={pairs!r} is unknown; use one of {PAIRINGS}")
    return evenly_spaced(out, max_pairs)


def evenly_spaced(items: list, n: int | None) -> list:
    """At most ``n`` of ``items``, evenly spaced and in order (all when ``n`` is None)."""
    if n is None or not 0 < n < len(items):
        return items
    keep = np.unique(np.linspace(0, len(items) - 1, n).round().astype(int))
    return [items[k] for k in keep]


def relative_errors(
    T_est1: np.ndarray,
    T_est2: np.ndarray,
    T_gt1: np.ndarray,
    T_gt2: np.ndarray,
    symmetry_axis: np.ndarray | None = None,
) -> dict[str, float]:
    """Errors of the relative pose of two views.

    Args:
        T_est1, T_est2: (4, 4) estimated ``T_template_camera`` of views 1 and 2.
        T_gt1, T_gt2: (4, 4) true ``T_object_camera`` of the two views (any frame shared by both).
        symmetry_axis: (3,) main axis in the object/template frame of a symmetric object, or None.

    Returns:
        ``rot_err_deg`` (geodesic angle between estimated and true ``R_c1_c2``), ``axis_err_deg``
        (NaN unless symmetric), ``trans_err`` (distance between the relative translations, in the
        object-normalised unit of the estimates; for symmetric objects the distance between where
        the two relative poses put the object's origin in camera 1, which a spin about the axis
        does not change) and ``err_deg`` (axis error if symmetric).
    """
    T_c1_c2_est = invert_T(np.asarray(T_est1, float)) @ np.asarray(T_est2, float)
    T_c1_c2_gt = invert_T(np.asarray(T_gt1, float)) @ np.asarray(T_gt2, float)
    rot = rotation_error_deg(T_c1_c2_est[:3, :3], T_c1_c2_gt[:3, :3])
    if symmetry_axis is None:
        trans = translation_error(T_c1_c2_est[:3, 3], T_c1_c2_gt[:3, 3])
        return {"rot_err_deg": rot, "axis_err_deg": float("nan"), "trans_err": trans, "err_deg": rot}
    # Main axis in camera 2 (from view 2's ground truth); compare where the two relative
    # poses put it in camera 1. axis_error_deg compares R_est^T a with R_gt^T a.
    T2 = np.asarray(T_gt2, float)
    a_c2 = T2[:3, :3].T @ np.asarray(symmetry_axis, float).reshape(3)
    axis = axis_error_deg(T_c1_c2_est[:3, :3].T, T_c1_c2_gt[:3, :3].T, a_c2)
    # the object's origin seen from camera 2, carried into camera 1 by both relative poses:
    # unlike the relative translation, this ignores each view's unobservable spin
    o_c2 = -T2[:3, :3].T @ T2[:3, 3]
    trans = translation_error(
        T_c1_c2_est[:3, :3] @ o_c2 + T_c1_c2_est[:3, 3], T_c1_c2_gt[:3, :3] @ o_c2 + T_c1_c2_gt[:3, 3]
    )
    return {"rot_err_deg": rot, "axis_err_deg": axis, "trans_err": trans, "err_deg": axis}


def _relative_angle_deg(r1: dict, r2: dict) -> float:
    """Geodesic angle of the true relative rotation between two views (inf when unknown)."""
    T1, T2 = row_array(r1.get("T_gt")), row_array(r2.get("T_gt"))
    if T1 is None or T2 is None:
        return float("inf")
    return rotation_error_deg(T1[:3, :3].T @ T2[:3, :3], np.eye(3))


class Relative(Protocol):
    """Relative pose between views of one instance, each view registered to a template.

    Args:
        template_source: ``"own"``: each view against the instance's own complete model
            (``dataset.instance_model``); ``"category"``: against the category templates
            (``dataset.category_templates``; with several, a view's estimate is the template
            the ``choice`` rule keeps, as in the ``templates`` protocol).
        pairs: ``"consecutive"`` (view k with view k+1, in sorted ``obs_id`` order) or ``"all"``.
        max_pairs_per_instance: keep at most this many pairs per instance (evenly spaced), or
            None for all.
        max_templates: with ``template_source="category"``, use only the first K templates.
        max_relative_angle_deg: keep only pairs whose true relative rotation is at most this
            (the paper's "< 45 deg" testing range), or None for all.
        exclude_templates: leave out the views of the category templates' own instances (with
            either source, so that ``own`` and ``category`` are scored on the same pairs).
        choice: with ``template_source="category"``, the rule that keeps a view's template (the
            ``choice`` config group, :class:`~catpose.methods.choice_rules.ChoiceRule`, or a rule name).
            Its ``view_templates`` are then the ``templates`` protocol's, so a run stores the cross
            check's facts the cross rules read.
    """

    name = "relative"

    def __init__(
        self,
        template_source: str = "category",
        pairs: str = "consecutive",
        max_pairs_per_instance: int | None = None,
        max_templates: int | None = None,
        max_relative_angle_deg: float | None = None,
        exclude_templates: bool = False,
        choice: str | ChoiceRule = DEFAULT_RULE,
    ) -> None:
        if template_source not in TEMPLATE_SOURCES:
            raise ConfigError(f"protocol.template_source={template_source!r} is unknown; use one of {TEMPLATE_SOURCES}")
        if pairs not in PAIRINGS:
            raise ConfigError(f"protocol.pairs={pairs!r} is unknown; use one of {PAIRINGS}")
        if max_pairs_per_instance is not None and int(max_pairs_per_instance) < 1:
            raise ConfigError(f"protocol.max_pairs_per_instance={max_pairs_per_instance} must be >= 1 or null")
        self.template_source = template_source
        self.pairs = pairs
        self.max_relative_angle_deg = None if max_relative_angle_deg is None else float(max_relative_angle_deg)
        self.max_pairs_per_instance = None if max_pairs_per_instance is None else int(max_pairs_per_instance)
        self.exclude_templates = bool(exclude_templates)
        self._views: Protocol = (
            GtModel()
            if template_source == "own"
            else Templates(max_templates=max_templates, exclude_templates=exclude_templates, choice=choice)
        )

    @property
    def view_templates(self):
        """The ``templates`` protocol's ``view_templates`` with category templates (a run stores the
        choice's facts on a view's K templates); None with the own model."""
        return getattr(self._views, "view_templates", None)

    def sample_ids(self, dataset: ObjectDataset) -> list[str]:
        """One registration per view (``"own"``) or per (view, template) (``"category"``)."""
        self._check_frames(dataset)
        ids = self._views.sample_ids(dataset)
        if self.exclude_templates and self.template_source == "own":
            ids = [i for i in ids if not is_excluded_view(i, dataset.category_templates(dataset.category_of(i)) or [])]
        return ids

    def _check_frames(self, dataset: ObjectDataset) -> None:
        # a constant template-to-instance rotation cancels in a relative pose, but two views that
        # pick differently oriented templates do not: category templates need consistent frames
        if self.template_source == "category":
            require_consistent_frames(dataset, "protocol=relative protocol.template_source=category")

    def load(self, dataset: ObjectDataset, sample_id: str) -> Sample:
        self._check_frames(dataset)
        sample = self._views.load(dataset, sample_id)
        obs_id = sample_id.rpartition("|")[0] if self.template_source == "category" else sample_id
        info = dict(sample.info)
        info.setdefault("absolute_gt", True)
        return Sample(problem=sample.problem, gt=sample.gt, group_id=obs_id, info=info)

    def view_rows(self, samples):
        """Per-sample rows -> one row per view (the chosen template's estimate)."""
        if self.template_source == "category":  # not score_units: that keeps absolute ground truth only
            return self._views.best_per_view(samples)
        return samples

    def score_units(self, samples):
        """Per-view registration rows -> one row per view pair of an instance.

        Needs the ``samples.jsonl`` columns ``category``, ``instance_id``, ``group_id`` (the
        view's ``obs_id``), ``status``, ``T_est``, ``T_gt``, ``symmetry_axis``, ``runtime_s`` and
        ``score``. Output rows keep the schema's columns (``err_deg``, ``status``, ...);
        ``sample_id`` is ``"<obs_id1>~<obs_id2>"``, ``group_id`` the instance, ``runtime_s`` and
        ``score`` the sums over the two views.
        """
        import pandas as pd

        if len(samples) == 0:
            return samples
        views = self.view_rows(samples)
        if "info" in views:  # views without a ground-truth frame shared with the others (a Redwood
            # scan with no trajectory: info["relative_gt"] False) cannot be scored; leave them out
            scorable = views["info"].map(lambda i: not (isinstance(i, dict) and i.get("relative_gt") is False))
            views = views[scorable.astype(bool)]
            if len(views) == 0:
                return views
        view = views["obs_id"].fillna(views["group_id"]) if "obs_id" in views else views["group_id"]
        views = views.assign(_view=view.astype(str)).sort_values("_view", kind="stable")
        # A view that failed to load has no instance id: take it from a "<category>/<instance>/<view>"
        # id; otherwise it cannot be paired and counts as one failed unit of its own.
        instance = views["instance_id"] if "instance_id" in views else pd.Series(None, index=views.index)
        parts = views["_view"].str.split("/")
        guess = parts.map(lambda p: p[1] if len(p) == 3 else None)
        views = views.assign(instance_id=instance.where(instance.notna(), guess))
        rows = []
        for r in views[views["instance_id"].isna()].to_dict("records"):
            why = f"view {r['_view']} failed ({r.get('error') or 'no estimate'}) and its instance is unknown"
            rows.append(failed_row(dict(r, sample_id=r["_view"]), why))
        known = views.dropna(subset=["instance_id"])
        for (category, instance), g in known.groupby(["category", "instance_id"], sort=True):
            g = g.drop_duplicates("_view")
            records = g.to_dict("records")
            candidates = pair_indices(len(records), self.pairs, None)
            if (max_deg := self.max_relative_angle_deg) is not None:
                candidates = [(i, j) for i, j in candidates if _relative_angle_deg(records[i], records[j]) <= max_deg]
            for i, j in evenly_spaced(candidates, self.max_pairs_per_instance):
                rows.append(self._pair_row(records[i], records[j], str(category), str(instance)))
        out = pd.DataFrame(rows)
        return out.drop(columns=["_view"], errors="ignore")

    def _pair_row(self, r1: dict, r2: dict, category: str, instance: str) -> dict:
        row = {k: v for k, v in r1.items() if k not in ("oracle_err_deg", "n_templates")}  # per view, not per pair
        row.update(
            sample_id=f"{r1['_view']}~{r2['_view']}",
            group_id=f"{category}/{instance}",
            obs_id=f"{r1['_view']}~{r2['_view']}",
            view1=r1["_view"],
            view2=r2["_view"],
            runtime_s=float(np.nansum([r1.get("runtime_s", np.nan), r2.get("runtime_s", np.nan)])),
            score=float(np.nansum([r1.get("score", np.nan), r2.get("score", np.nan)])),
        )
        failed = [r for r in (r1, r2) if r.get("status") != "ok" or row_array(r.get("T_est")) is None]
        if failed:
            why = f"view {failed[0]['_view']} failed: {failed[0].get('error') or 'no estimate'}"
            nan = float("nan")
            return failed_row(row, why, rot_err_deg=FAILED_ERROR_DEG, axis_err_deg=nan, trans_err=nan)
        T_gt1, T_gt2 = row_array(r1.get("T_gt")), row_array(r2.get("T_gt"))
        axis = row_array(r1.get("symmetry_axis"), (3,))
        errors = relative_errors(row_array(r1["T_est"]), row_array(r2["T_est"]), T_gt1, T_gt2, axis)
        T_rel_est = invert_T(row_array(r1["T_est"])) @ row_array(r2["T_est"])
        T_rel_gt = invert_T(T_gt1) @ T_gt2
        stage, T_gt = row.get("stage", ""), T_rel_gt.reshape(-1).tolist()
        return scored_row(row, T_rel_est, errors, stage=stage, T_gt=T_gt, symmetric=axis is not None)
