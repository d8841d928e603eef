"""Typed option groups of ``ours`` (:class:`~catpose.methods.ours.Ours`): the solver, the choice
among candidates and the resting-pose search. Built by Hydra from ``configs/method/ours.yaml``
(``method.optimiser.*``, ``method.selection.*``, ``method.resting.*``, the one place of their
defaults); invalid values raise a one-line ConfigError naming the key. Values no user or study
changes are named constants in the stage that uses them (each says where it was chosen:
``docs/choosing-defaults.md``)."""

from __future__ import annotations

from dataclasses import dataclass

from catpose.errors import ConfigError
from catpose.methods import options


@dataclass(frozen=True)
class OptimiserSettings:
    """The two optimisation stages on all candidates (paper Section III-D).

    Attributes:
        solver: ``irls`` (default: each stage in closed form by iteratively reweighted Kabsch,
            :mod:`catpose.methods.ours.irls`) or ``adam`` (the paper's Adam on 6D rotation,
            translation and correspondence logits, :mod:`catpose.methods.ours.adam`).
        mode: ``joint`` (stage 1 pose, then stage 2 pose + correspondences; the paper), ``pose``
            (stage 1 only) or ``none`` (the SVD initial pose only).
        irls_iterations: IRLS iterations per stage at most (each candidate also stops on
            convergence).
        steps_pose, steps_joint: (adam) Adam steps of stage 1 and stage 2 (paper: 300 each).
        lr: (adam) learning rate of both stages (paper: 1e-3; default 1e-2, see the config).
        device: torch device, ``cpu`` or ``cuda``.
    """

    solver: str = "irls"
    mode: str = "joint"
    irls_iterations: int = 5
    steps_pose: int = 300
    steps_joint: int = 300
    lr: float = 1e-2
    device: str = "cpu"

    def __post_init__(self) -> None:
        k, set_ = "method.optimiser.", object.__setattr__
        set_(self, "mode", options.one_of(k + "mode", self.mode, ("joint", "pose", "none")))
        for key in ("steps_pose", "steps_joint"):
            set_(self, key, options.non_negative(k + key, getattr(self, key), integer=True))
        set_(self, "lr", options.positive(k + "lr", self.lr))
        set_(self, "solver", options.one_of(k + "solver", self.solver, ("irls", "adam")))
        set_(self, "irls_iterations", options.positive(k + "irls_iterations", self.irls_iterations, integer=True))
        if str(self.device).startswith("cuda"):
            import torch

            if not torch.cuda.is_available():
                raise ConfigError(f"{k}device={self.device!r} but torch has no CUDA device here; use device=cpu")
        elif self.device != "cpu":
            raise ConfigError(f"{k}device={self.device!r} is unknown; use cpu or cuda")


@dataclass(frozen=True)
class SelectionSettings:
    """Choosing one pose, then refining it.

    Attributes:
        rule: ``depth`` (where the problem has a depth image and the template a mesh: the
            occlusion-aware depth check, :mod:`catpose.methods.ours.check`, chooses among the
            dictionary's candidates and the resting-pose search's poses,
            :mod:`catpose.methods.ours.choice`; otherwise the ``visibility`` rule), ``visibility``
            (the ``top_k`` candidates by the visibility-aware Chamfer, each with its three half
            turns, refined, then the lowest visibility-aware Chamfer), ``chamfer`` (lowest
            one-directional Chamfer distance of the transformed input to the complete template)
            or ``loss`` (lowest final loss; the paper's rule).
        gravity_max_deg: drop candidates tilting the ground normal more than this (degrees) from
            a resting up of the template; ``None`` or <= 0: off.
        refine: point-to-plane ICP of the chosen poses (false: the paper;
            :mod:`catpose.methods.ours.refine`).
        top_k: ``visibility``: candidates expanded by half turns (each costs 4 refinements).
        depth_tau: ``depth``: depth tolerance of the check (object-normalised unit).
        depth_free_weight: ``depth``: cost of a free-space violation relative to an unexplained
            mask pixel.
        depth_top_k: ``depth``: poses of the pool (by their depth cost) refined and scored again.
        depth_final_refine: ``depth``: poses refined on the mask's pixels of the final lattice
            (against a fixed sample of the mesh: no seed draws them) and compared on that
            lattice at the end.
        depth_final_pixels: ``depth``: lattice pixels in the mask of the last comparisons.
        depth_min_inliers: ``depth``: when the winner explains fewer of the mask's inner pixels
            than this, the template is taken to be unlike the object and the ``chamfer`` rule
            chooses among the candidates of the template's own up instead.
        depth_fit_erode_px: ``depth``: that test counts only the mask pixels at least this many
            image pixels inside the mask's edge (0: the whole mask): a mask that bleeds onto
            its neighbours or misses its own rim leaves the inside explained by a right pose.
    """

    rule: str = "depth"
    gravity_max_deg: float | None = 30.0
    refine: bool = True
    top_k: int = 3
    depth_tau: float = 0.15
    depth_free_weight: float = 2.0
    depth_top_k: int = 5
    depth_final_refine: int = 2
    depth_final_pixels: int = 2400
    depth_min_inliers: float = 0.95
    depth_fit_erode_px: int = 3

    def __post_init__(self) -> None:
        k, set_ = "method.selection.", object.__setattr__
        set_(self, "rule", options.one_of(k + "rule", self.rule, ("depth", "visibility", "chamfer", "loss")))
        set_(self, "depth_tau", options.positive(k + "depth_tau", self.depth_tau))
        set_(self, "depth_free_weight", options.non_negative(k + "depth_free_weight", self.depth_free_weight))
        set_(self, "depth_min_inliers", options.non_negative(k + "depth_min_inliers", self.depth_min_inliers))
        for key in ("depth_fit_erode_px",):
            set_(self, key, options.non_negative(k + key, getattr(self, key), integer=True))
        for key in ("depth_final_pixels", "depth_top_k", "depth_final_refine", "top_k"):
            set_(self, key, options.positive(k + key, getattr(self, key), integer=True))
        g = self.gravity_max_deg
        if g is not None and not options.is_number(g):
            raise ConfigError(f"{k}gravity_max_deg={g!r} must be a number of degrees or null (off)")
        set_(self, "gravity_max_deg", None if g is None or g <= 0 else float(g))
        set_(self, "refine", options.flag(k + "refine", self.refine))


@dataclass(frozen=True)
class RestingSettings:
    """Gravity hypotheses beyond the template's own up axis (``rule=depth`` with a depth image).

    The gravity filter, the LPS frames and the dictionary's viewpoints assume the object stands on
    the template's up axis. An object on its side or upside down breaks all three. Each stable
    resting direction of the template (:func:`catpose.resting.resting_ups`; classes merged under a
    continuous symmetry) is searched by the coarse search over every resting pose x yaw
    (:mod:`catpose.methods.ours.rest_search`), whose poses compete with the dictionary's in the
    depth check.

    Attributes:
        max_poses: resting directions tried besides the template's up (0: only the template's up),
            the most probable first.
        min_probability: directions less probable than this (drop-test probability of the
            template's convex hull) are not tried.
        grid_yaws: the coarse search: yaws per resting direction (0: off).
        grid_beam: poses of lowest one-directional Chamfer distance after its first ICP pass that
            go on to the full pass (0: one pass, all).
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
    grid_yaws: int = 8
    grid_beam: int = 32
    grid_icp: str = "union"
    grid_shift: float = 0.5

    def __post_init__(self) -> None:
        k, set_ = "method.resting.", object.__setattr__
        for key in ("max_poses", "grid_yaws", "grid_beam"):
            set_(self, key, options.non_negative(k + key, getattr(self, key), integer=True))
        set_(self, "min_probability", options.non_negative(k + "min_probability", self.min_probability))
        set_(self, "grid_icp", options.one_of(k + "grid_icp", self.grid_icp, ("yaw", "full", "union")))
        set_(self, "grid_shift", options.non_negative(k + "grid_shift", self.grid_shift))
