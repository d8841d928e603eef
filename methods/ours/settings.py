"""Typed option groups of ``ours`` (:class:`~catpose.methods.ours.Ours`): the optimiser and the
selection among candidates. Built by Hydra from ``configs/method/ours.yaml``
(``method.optimiser.*``, ``method.selection.*``); invalid values raise a one-line ConfigError
naming the key."""

from __future__ import annotations

from dataclasses import dataclass

from catpose.errors import ConfigError
from catpose.methods import options


@dataclass(frozen=True)
class OptimiserSettings:
    """The two optimisation stages on all candidates (paper Section III-D).

    Attributes:
        solver: ``irls`` (default: each stage in closed form by iteratively reweighted Kabsch,
            :mod:`catpose.methods.ours.irls`) or ``adam`` (the paper's Adam on 6D rotation, translation
            and correspondence logits, :mod:`catpose.methods.ours.adam`).
        irls_iterations: IRLS iterations per stage at most (each candidate also stops on
            convergence); irls_beta: stage-2 sharpness (1 / object-normalised unit, the KL trust
            region to the affinity is 1 / beta); irls_tol: relative objective decrease to stop.
        mode: ``joint`` (stage 1 pose, then stage 2 pose + correspondences; the paper), ``pose``
            (stage 1 only) or ``none`` (the SVD initial pose only).
        steps_pose, steps_joint: (adam) Adam steps of stage 1 and stage 2 (paper: 300 each).
        lr: (adam) learning rate of both stages (paper: 1e-3; default 1e-2, see the config).
        stage2_top_k: if in (0, m), stage 2 runs only on the ``k`` best candidates after stage 1
            (by the selection criterion); 0 runs it on all ``m`` (the paper).
        chamfer_weight: (adam) weight of the one-directional Chamfer term (input -> complete
            template; 0: off).
        device: torch device, ``cpu`` or ``cuda``.
    """

    mode: str = "joint"
    steps_pose: int = 300
    steps_joint: int = 300
    lr: float = 1e-2
    stage2_top_k: int = 0
    chamfer_weight: float = 0.0
    device: str = "cpu"
    solver: str = "irls"
    irls_iterations: int = 5
    irls_beta: float = 10.0
    irls_tol: float = 1e-4

    def __post_init__(self) -> None:
        k, set_ = "method.optimiser.", object.__setattr__
        set_(self, "mode", options.one_of(k + "mode", self.mode, ("joint", "pose", "none")))
        for key in ("steps_pose", "steps_joint", "stage2_top_k"):
            set_(self, key, options.non_negative(k + key, getattr(self, key), integer=True))
        set_(self, "lr", options.positive(k + "lr", self.lr))
        set_(self, "solver", options.one_of(k + "solver", self.solver, ("irls", "adam")))
        set_(self, "irls_iterations", options.positive(k + "irls_iterations", self.irls_iterations, integer=True))
        set_(self, "irls_beta", options.positive(k + "irls_beta", self.irls_beta))
        set_(self, "irls_tol", options.non_negative(k + "irls_tol", self.irls_tol))
        set_(self, "chamfer_weight", options.non_negative(k + "chamfer_weight", self.chamfer_weight))
        if self.chamfer_weight > 0 and self.solver == "irls":
            raise ConfigError(
                f"{k}chamfer_weight={self.chamfer_weight} needs {k}solver=adam (the IRLS solver has no Chamfer term)"
            )
        if str(self.device).startswith("cuda"):
            import torch

            if not torch.cuda.is_available():
                raise ConfigError(f"{k}device={self.device!r} but torch has no CUDA device here; use device=cpu")
        elif self.device != "cpu":
            raise ConfigError(f"{k}device={self.device!r} is unknown; use cpu or cuda")


@dataclass(frozen=True)
class SelectionSettings:
    """Choosing one of the ``m`` candidates, then refining it.

    Attributes:
        rule: ``depth`` (where the problem has a depth image and the template a mesh: the
            occlusion-aware depth check of :mod:`catpose.methods.ours.check` scores the
            candidates of every resting hypothesis, the ``top_k`` best are expanded by their half
            turns, refined and scored again, and the best wins; otherwise the ``depth_fallback``
            rule), ``visibility`` (the ``top_k`` candidates by the visibility-aware Chamfer,
            each with its three half turns, refined, then the lowest visibility-aware Chamfer;
            :func:`catpose.methods.pose_scores.select_with_half_turns`), ``chamfer`` (lowest
            one-directional Chamfer distance of the transformed input to the complete template)
            or ``loss`` (lowest final loss; the paper's rule).
        gravity_max_deg: drop candidates tilting the ground normal more than this (degrees) from
            the template's up axis; ``None`` or <= 0: off.
        refine: point-to-plane ICP from the selected pose (false: the paper).
        refine_max_distance: ICP correspondence distance (object-normalised).
        refine_iterations: ICP iterations.
        top_k: ``visibility``: candidates expanded by half turns (each costs 4 refinements).
        visibility_trunc: ``visibility``: truncation of both Chamfer directions (object-normalised).
        refine_top: ``visibility``: refine only this many of the ``4 top_k`` hypotheses, the best
            by their score before refinement (0: all of them).
        depth_tau: ``depth``: depth tolerance (object-normalised unit).
        depth_pixels: ``depth``: lattice pixels wanted inside the object's mask.
        depth_max_rays: ``depth``: at most this many rays per pose (a coarser lattice otherwise).
        depth_free_weight: ``depth``: cost of a free-space violation relative to an unexplained
            mask pixel.
        depth_fine_distance: ``depth``: after the refinement on all points, the last poses are
            refined again pairing only within this distance (0: not).
        depth_final_pixels: ``depth``: lattice pixels in the mask for the last comparisons (of the
            ``depth_final_refine`` poses, and of the winner with its half turns; at most
            ``depth_pixels`` means the same lattice).
        depth_final_turns: ``depth``: the winner meets this many of its (three, two for a
            template with a symmetry axis) half turns about the template's axes, those the coarse
            lattice scores best, each refined on all input points and compared on the final
            lattice (0: none; true / false read as 1 / 0).
        depth_polish_levels: ``depth``: after the last comparison, the winner and its half turns
            about the template's axes are each polished by a local search on the final lattice's
            depth cost (:func:`catpose.methods.ours.polish.polish`) with this many levels, and the
            one that costs least wins (0: off).
        depth_polish_deg, depth_polish_shift: that search's first turn (degrees) and shift
            (object-normalised unit), halved at each level.
        depth_top_k: ``depth``: candidates (of all gravity hypotheses, by their depth score) expanded
            by their half turns and refined.
        depth_half_turns: ``depth``: the ``depth_top_k`` candidates go on with their three half turns
            (false: alone; the coarse search holds every resting pose and yaw).
        depth_final_refine: ``depth``: poses refined on all input points and scored again at the
            end (the best by their score after the refinement on the Chamfer subset).
        depth_final_distinct_deg: ``depth``: those poses differ pairwise by more than this
            rotation, degrees (for a template with a symmetry axis: the axis' direction; a spin
            about it is no difference): a pose and its own refined or unrefined copy do not take
            two places (0: the best regardless).
        depth_yaw_turns: ``depth``: in the escalated pass (``resting.escalate_below``), each
            expanded candidate is also tried turned about the template's up by every multiple of
            ``360 / depth_yaw_turns`` degrees (:func:`catpose.methods.pose_scores.yaw_and_half_turns`;
            none for a template with a symmetry axis; 0 or 1: half turns only).
        depth_rest_prior: ``depth``: cost added to a pose that rests other than on the template's
            up (a tie-break towards the upright object; 0: none).
        depth_prescreen: ``depth``: candidates of each gravity hypothesis scored by the depth check,
            those of lowest one-directional Chamfer distance (0: all).
        depth_min_inliers: ``depth``: when the best pose explains fewer of the mask's pixels than
            this within ``depth_fit_tau``, the template is taken to be unlike the object and
            ``depth_poor_fit_rule`` chooses among the candidates of the template's own up instead.
        depth_fit_tau: ``depth``: the tolerance of that test (object-normalised unit).
        depth_fit_erode_px: ``depth``: that test counts only the mask pixels at least this many
            image pixels inside the mask's edge (0: the whole mask): a mask that bleeds onto
            its neighbours or misses its own rim leaves the inside explained by a right pose.
        depth_poor_fit_rule: that rule (``chamfer``, ``visibility`` or ``loss``).
        depth_poor_fit_max_ratio: that rule's answer is taken only when its depth score is at
            most this many times the depth check's winner's (an answer that explains the image
            far worse is a wrong pose, not a sign of a template unlike the object); 0: always.
        depth_fallback: the rule used when ``rule=depth`` has no depth image or no template mesh
            (``visibility``, ``chamfer`` or ``loss``).
    """

    rule: str = "depth"
    gravity_max_deg: float | None = 30.0
    refine: bool = True
    refine_max_distance: float = 0.05
    refine_iterations: int = 30
    top_k: int = 3
    visibility_trunc: float = 0.1
    refine_top: int = 0
    depth_tau: float = 0.15
    depth_pixels: int = 300
    depth_max_rays: int = 2500
    depth_free_weight: float = 2.0
    depth_prescreen: int = 6
    depth_rest_prior: float = 0.0
    depth_top_k: int = 5
    depth_final_refine: int = 2
    depth_final_distinct_deg: float = 0.0
    depth_yaw_turns: int = 12
    depth_final_pixels: int = 2400
    depth_final_turns: int = 1
    depth_polish_levels: int = 0
    depth_polish_deg: float = 4.0
    depth_polish_shift: float = 0.04
    depth_half_turns: bool = False
    depth_fine_distance: float = 0.0
    depth_min_inliers: float = 0.95
    depth_fit_tau: float = 0.2
    depth_fit_erode_px: int = 3
    depth_poor_fit_rule: str = "chamfer"
    depth_poor_fit_max_ratio: float = 0.0
    depth_fallback: str = "visibility"

    def __post_init__(self) -> None:
        k, set_ = "method.selection.", object.__setattr__
        set_(self, "rule", options.one_of(k + "rule", self.rule, ("depth", "visibility", "chamfer", "loss")))
        set_(
            self,
            "depth_fallback",
            options.one_of(k + "depth_fallback", self.depth_fallback, ("visibility", "chamfer", "loss")),
        )
        set_(self, "depth_tau", options.positive(k + "depth_tau", self.depth_tau))
        set_(self, "depth_pixels", options.positive(k + "depth_pixels", self.depth_pixels, integer=True))
        set_(self, "depth_max_rays", options.positive(k + "depth_max_rays", self.depth_max_rays, integer=True))
        set_(self, "depth_free_weight", options.non_negative(k + "depth_free_weight", self.depth_free_weight))
        set_(self, "depth_min_inliers", options.non_negative(k + "depth_min_inliers", self.depth_min_inliers))
        set_(self, "depth_fit_tau", options.positive(k + "depth_fit_tau", self.depth_fit_tau))
        set_(
            self,
            "depth_fit_erode_px",
            options.non_negative(k + "depth_fit_erode_px", self.depth_fit_erode_px, integer=True),
        )
        set_(
            self,
            "depth_poor_fit_rule",
            options.one_of(k + "depth_poor_fit_rule", self.depth_poor_fit_rule, ("visibility", "chamfer", "loss")),
        )
        set_(
            self,
            "depth_poor_fit_max_ratio",
            options.non_negative(k + "depth_poor_fit_max_ratio", self.depth_poor_fit_max_ratio),
        )
        set_(self, "depth_fine_distance", options.non_negative(k + "depth_fine_distance", self.depth_fine_distance))
        set_(
            self,
            "depth_final_pixels",
            options.positive(k + "depth_final_pixels", self.depth_final_pixels, integer=True),
        )
        set_(self, "depth_top_k", options.positive(k + "depth_top_k", self.depth_top_k, integer=True))
        set_(
            self,
            "depth_final_refine",
            options.positive(k + "depth_final_refine", self.depth_final_refine, integer=True),
        )
        set_(
            self,
            "depth_final_distinct_deg",
            options.non_negative(k + "depth_final_distinct_deg", self.depth_final_distinct_deg),
        )
        set_(self, "depth_yaw_turns", options.non_negative(k + "depth_yaw_turns", self.depth_yaw_turns, integer=True))
        set_(self, "depth_rest_prior", options.non_negative(k + "depth_rest_prior", self.depth_rest_prior))
        set_(self, "depth_prescreen", options.non_negative(k + "depth_prescreen", self.depth_prescreen, integer=True))
        g = self.gravity_max_deg
        if g is not None and not options.is_number(g):
            raise ConfigError(f"{k}gravity_max_deg={g!r} must be a number of degrees or null (off)")
        set_(self, "gravity_max_deg", None if g is None or g <= 0 else float(g))
        set_(self, "refine", options.flag(k + "refine", self.refine))
        set_(self, "depth_half_turns", options.flag(k + "depth_half_turns", self.depth_half_turns))
        turns = self.depth_final_turns
        turns = int(turns) if isinstance(turns, bool) else turns  # true / false: 1 / 0 (the key was a flag)
        set_(self, "depth_final_turns", options.non_negative(k + "depth_final_turns", turns, integer=True))
        set_(
            self,
            "depth_polish_levels",
            options.non_negative(k + "depth_polish_levels", self.depth_polish_levels, integer=True),
        )
        set_(self, "depth_polish_deg", options.positive(k + "depth_polish_deg", self.depth_polish_deg))
        set_(self, "depth_polish_shift", options.positive(k + "depth_polish_shift", self.depth_polish_shift))
        set_(self, "refine_max_distance", options.positive(k + "refine_max_distance", self.refine_max_distance))
        set_(
            self,
            "refine_iterations",
            options.non_negative(k + "refine_iterations", self.refine_iterations, integer=True),
        )
        set_(self, "top_k", options.positive(k + "top_k", self.top_k, integer=True))
        set_(self, "refine_top", options.non_negative(k + "refine_top", self.refine_top, integer=True))
        set_(self, "visibility_trunc", options.positive(k + "visibility_trunc", self.visibility_trunc))


@dataclass(frozen=True)
class RestingSettings:
    """Gravity hypotheses beyond the template's own up axis (``rule=depth`` with a depth image).

    The gravity filter, the LPS frames and the dictionary's viewpoints assume the object stands on
    the template's up axis. An object on its side or upside down breaks all three. Each stable
    resting direction of the template (:func:`catpose.resting.resting_ups`; classes merged under a
    continuous symmetry) becomes a hypothesis: the pipeline runs on the template turned so that
    direction is up, and every hypothesis' candidates compete in the depth check.

    Attributes:
        max_poses: resting directions tried besides the template's up (0: only the template's up),
            the most probable first.
        min_probability: directions less probable than this (drop-test probability of the
            template's convex hull) are not tried.
        merge_deg: resting directions closer than this are one.
        escalate_below: the dictionary runs on the other resting directions too only when the
            best pose explains fewer of the object mask's pixels than this (1: always; 0: never).
        grid_yaws: the coarse search (:mod:`catpose.methods.ours.rest_search`): yaws per resting
            direction (0: off).
        grid_iterations: its ICP steps of the full pass (on the input's Chamfer subset).
        grid_max_distance: its ICP pairing distance (object-normalised unit).
        grid_keep: its poses of lowest depth cost that join the dictionary's candidates.
        grid_points: input points (the head of the Chamfer subset, itself in farthest-point
            order) of its first ICP pass (of its one pass when ``grid_beam`` is 0).
        grid_template_points: template points (farthest-point subset) its ICP pairs them with.
        grid_beam: poses of lowest one-directional Chamfer distance after the first pass
            (``grid_first_iterations`` steps) that go on to the full pass (0: one pass, all).
        grid_first_iterations: ICP steps of the first pass.
        grid_pixels: lattice pixels in the mask its depth check scores (at most
            ``selection.depth_pixels``: the same lattice).
        grid_icp: its ICP's freedom: ``yaw`` (a turn about the ground normal and a translation:
            the pose keeps the resting direction it was put in, :mod:`catpose.yaw_icp_kernel`),
            ``full`` (every rotation and translation: it can tilt into a rest the template lacks,
            and drift out of a right one) or ``union`` (both searches, their poses pooled).
        grid_shift: a resting direction along the symmetry axis (one yaw) also starts from
            ``grid_yaws - 1`` placements moved along the ground by this fraction of the template's
            radius about it (0: one start).
    """

    max_poses: int = 10
    min_probability: float = 0.01
    merge_deg: float = 10.0
    escalate_below: float = 0.0
    grid_yaws: int = 8
    grid_iterations: int = 10
    grid_max_distance: float = 0.15
    grid_keep: int = 8
    grid_points: int = 64
    grid_template_points: int = 2048
    grid_beam: int = 32
    grid_first_iterations: int = 3
    grid_pixels: int = 300
    grid_icp: str = "union"
    grid_shift: float = 0.5

    def __post_init__(self) -> None:
        k, set_ = "method.resting.", object.__setattr__
        set_(self, "max_poses", options.non_negative(k + "max_poses", self.max_poses, integer=True))
        set_(self, "min_probability", options.non_negative(k + "min_probability", self.min_probability))
        set_(self, "merge_deg", options.positive(k + "merge_deg", self.merge_deg))
        set_(self, "escalate_below", options.non_negative(k + "escalate_below", self.escalate_below))
        set_(self, "grid_yaws", options.non_negative(k + "grid_yaws", self.grid_yaws, integer=True))
        set_(self, "grid_iterations", options.non_negative(k + "grid_iterations", self.grid_iterations, integer=True))
        set_(self, "grid_max_distance", options.positive(k + "grid_max_distance", self.grid_max_distance))
        set_(self, "grid_keep", options.non_negative(k + "grid_keep", self.grid_keep, integer=True))
        set_(self, "grid_points", options.positive(k + "grid_points", self.grid_points, integer=True))
        set_(self, "grid_beam", options.non_negative(k + "grid_beam", self.grid_beam, integer=True))
        set_(
            self,
            "grid_first_iterations",
            options.non_negative(k + "grid_first_iterations", self.grid_first_iterations, integer=True),
        )
        set_(
            self,
            "grid_template_points",
            options.positive(k + "grid_template_points", self.grid_template_points, integer=True),
        )
        set_(self, "grid_pixels", options.positive(k + "grid_pixels", self.grid_pixels, integer=True))
        set_(self, "grid_icp", options.one_of(k + "grid_icp", self.grid_icp, ("yaw", "full", "union")))
        set_(self, "grid_shift", options.non_negative(k + "grid_shift", self.grid_shift))
