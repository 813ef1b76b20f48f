"""Typed configuration of the safe optimisers: the one place every default is defined.

:class:`ksbo_mav.opt.options.Options` (what ``optimize(**options)`` validates) is the composition of these
dataclasses, so a field such as ``beta`` has one default whether it is read through ``Options`` or through the
:class:`SafeBOConfig` the state machine receives.

Defaults were tuned on the planar quadrotor, tuning seeds 100+ (benchmarks/notes/plants.md).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class SafeBOConfig:
    """Settings of :class:`ksbo_mav.opt.methods.safe_bo.SafeBO`.

    Attributes:
        beta: safety multiplier: certified safe ⇔ μ − beta σ ≥ p_min.
        beta_ucb: exploration multiplier of the UCB acquisition; None = ``beta``.
        rule: ``"ucb"`` (boundary expansion for ``expansion_iters`` BO iterations, then safe UCB) or
            ``"safeopt"`` (widest interval among plausible maximisers and boundary points).
        expansion_iters: BO iterations of boundary exploration under the ``"ucb"`` rule (at most a tenth of the
            budget, so a 30-flight vehicle campaign spends 3 on it).
        boundary_tol: boundary band ``LCB − p_min ≤ boundary_tol × signal_std``.
        n_global, n_local: global Sobol / local Gaussian candidates per iteration.
        local_scales: standard deviations (unit cube) of the local clouds.
        n_anchors: certified-safe observations the clouds are centred on (best by UCB, then random).
        refine_starts, refine_rounds, refine_samples, refine_scale: constrained local refinement (candidates.refine).
        refit_every: full refit every this many iterations; 0 = rank-one updates only.
        recommend: ``"mean"`` or ``"lcb"``: criterion among evaluated certified-safe points.
        cap_mean: the safety bound uses ``min(μ, max observed y)`` (an overshooting mean is extrapolation).
        recommend_noise: the recommendation uses a second GP with noise std ``recommend_noise × signal_std``
            (averages a lucky episode of a bistable gain with its crashed neighbours); None = the model itself.
        y_max: known upper bound of the objective (clips posterior means).
        exploit_last: the last this many evaluations (at most a fifth of the budget) maximise
            ``μ − exploit_beta·σ`` inside the safe set.
        exclusion_radius: no certified candidate closer than this (unit cube) to an unsafe or failed trial.
        explore_from: ``"x0"`` (clouds grow from the start and the optimiser's own evaluations; prior points join
            once reached; no global points) or ``"all"``.
        exploit_beta: see ``exploit_last``.
    """

    beta: float = 4.0
    beta_ucb: float | None = 2.0
    rule: str = "ucb"
    expansion_iters: int = 10
    boundary_tol: float = 0.1
    n_global: int = 256
    n_local: int = 1536
    local_scales: tuple[float, ...] = (0.02, 0.05, 0.1, 0.2)
    n_anchors: int = 32
    refine_starts: int = 8
    refine_rounds: int = 4
    refine_samples: int = 32
    refine_scale: float = 0.05
    refit_every: int = 0
    recommend: str = "lcb"
    cap_mean: bool = True
    recommend_noise: float | None = 0.2
    y_max: float | None = None
    # Tuned on seeds 100-119: the last 20 evaluations exploit; growing the search from x0.
    exploit_last: int = 20
    exclusion_radius: float = 0.05
    explore_from: str = "x0"
    exploit_beta: float = 0.0

@dataclass(frozen=True)
class AdaptiveConfig:
    """Learned safety scale, trust region, abort-and-restore exploration, re-flown recommendation.

    Attributes:
        censor_aborts: aborted and crashed trials are censored: the GPs never see their value; they enter the
            failure model (P(abort), P(crash)), which then restricts queries (and the recommendation) to points
            predicted to abort with probability ≤ ``abort_tol``. False: they enter the GPs with their recorded value
            (the paper's method, strict or not).
        learn_safety_scale: fit the safety GP's per-dimension lengthscales by marginal likelihood (log-normal
            hyperprior ``safety_scale_prior`` = (median, log-sd), bounds ``safety_scale_bounds``) every
            ``scale_refit_every`` evaluations (every evaluation for the first ``4 × scale_refit_every``), on
            completed trials; no lengthscale exceeds ``scale_extent_factor`` × the data's extent along its
            dimension, and before any fit the scale starts at ``safety_scale_bounds[0]`` (small steps first).
        trust_region: candidates stay in a box around the incumbent whose half-width grows ×``tr_grow`` after
            every ``tr_success`` trials that become the incumbent and shrinks ×``tr_shrink`` after an abort or
            crash, which also resets the count (opt.acquisition.trust_region).
        max_aborts: abort budget, a hard cap: once that many trials of the run aborted or crashed the run ends
            (so it is never exceeded). None = no cap.
        backup_beta: None = only certified queries (β), the paper's rule. A number enables exploration the
            backup covers: while the abort budget lasts, trials may leave the certified set if certified with
            ``backup_beta`` instead of ``beta``, inside the trust region, where the failure model predicts
            P(abort) ≤ ``abort_tol`` and P(crash) ≤ ``crash_tol``, and only until the first crash (the backup is
            then known not to catch this plant's failures). Off by default: on the planar suite the failures are
            mostly fast pitch divergences the backup cannot catch. A tuning campaign sets it (0.5) for vehicle
            profiles that declare ``[safety] backup_covers_trials`` (outer loops clipped by a lean-angle limit;
            ``ksbo_mav.campaign.config.profile_defaults``; benchmarks/notes/plants.md).
        refly_last: the last this many evaluations (at most a tenth of the budget) re-fly the ``refly_top`` best
            completed points (by the recommendation's criterion, and the best single flight); the recommendation
            is then the best mean over each point's flights (once any trial failed: the best expected score under
            the failure model, and a candidate that failed is not re-flown; opt.methods.recommend).
        refly_stress: where the objective has a stress start (``fun.stress(x)``, e.g.
            :meth:`ksbo_mav.simulated.planar_objective.SimObjective.stress`, a planar MAVLink campaign's moving
            starts), the re-fly phase first flies each candidate once from it, and only candidates that pass are
            re-flown and can be recommended (opt.methods.refly): gains that fail from part of the starts fail there
            first. An objective without ``stress`` (the copters) re-flies as usual. On in ``ksbo-adaptive``
            (opt.options).
        reselect_every: every this many BO iterations ksbo re-selects its additive orders on the completed data
            by marginal likelihood (Algorithm 1 stays the first selection); 0 = never (the paper's once-only
            selection). ``ksbo`` and ``ksbo-adaptive`` default to 10 (opt.options).
        exclusion_growth, exclusion_max: the exclusion ball (``exclusion_radius``) of a bad trial grows
            ×``exclusion_growth`` (up to ``exclusion_max``) each time a later bad trial lands within twice its
            radius (opt.acquisition.exclusion); 1 = fixed balls. Fallbacks then avoid the balls too.
        failure_scale_shrink: each trial at new gains that aborts or crashes multiplies the safety lengthscales
            (learnt, or the fixed one with ``learn_safety_scale`` off) by this (a certified point failed: the GP
            claimed too much smoothness); 1 = off.
        unsafe_scale_shrink: the same for a completed trial at new gains that scored below p_min (the strict
            mode's unsafe flight): the plant is less smooth than assumed there; 1 = off.
        ard_acquisition: > 0: the UCB (and the candidate anchors) come from a copy of the main GP whose base
            lengthscale along each dimension is raised to ``ard_acquisition`` × the learnt safety lengthscale
            there, so a step along a dimension the data show to be flat earns little uncertainty bonus. Safety (the
            LCB) stays with the main and safety GPs. 0 = the main GP's UCB.
    """

    censor_aborts: bool = False
    learn_safety_scale: bool = False
    safety_scale_prior: tuple[float, float] = (0.1, 1.0)
    safety_scale_bounds: tuple[float, float] = (0.01, 1.0)
    scale_refit_every: int = 5
    scale_extent_factor: float = 2.0
    trust_region: bool = False
    tr_init: float = 0.1
    tr_min: float = 0.02
    tr_max: float = 0.5
    tr_grow: float = 2.0
    tr_shrink: float = 0.5
    tr_success: int = 2
    max_aborts: int | None = None
    backup_beta: float | None = None
    abort_tol: float = 0.3
    crash_tol: float = 0.1
    refly_last: int = 0
    refly_top: int = 3
    refly_stress: bool = False
    reselect_every: int = 0
    exclusion_growth: float = 1.0
    exclusion_max: float = 0.2
    failure_scale_shrink: float = 1.0
    unsafe_scale_shrink: float = 1.0
    ard_acquisition: float = 0.0


@dataclass(frozen=True)
class ModelConfig:
    """GP priors (unit cube; see opt.models.safety_model.ModelSpec): lengthscale, signal/noise scales, the safety GP.

    ``safety_kernel="se"`` makes an SE-ARD GP with ``safety_lengthscale`` certify every query as well.
    ``optimize_hypers``: ML-II on refits of the main GP.
    """

    lengthscale: float = 0.1
    signal_std: float | None = None
    signal_scale: float = 2.0
    noise_std: float | None = None
    noise_ratio: float = 0.02
    safety_kernel: str = "se"
    safety_lengthscale: float = 0.05
    optimize_hypers: bool = False


@dataclass(frozen=True)
class SelectionConfig:
    """Kernel selection of ksbo (opt.models.selection): fixed ``orders`` skip it; ``top`` orders kept among
    1..``max_order`` by ``trials`` repetitions of Algorithm 1 once ``min_select`` observations exist (else
    ``default_orders``); ``dims`` per-order dimension selection; ``select_at`` a C_ree re-selection after that
    many iterations; ``dropped`` what happens to unselected dimensions ("fixed" at x0 or "order1")."""

    orders: tuple[int, ...] | None = None
    top: int = 3
    trials: int = 200
    min_select: int = 10
    max_order: int | None = None
    select_at: int = 0
    default_orders: tuple[int, ...] = (1, 2, 3)
    dims: str = "all"
    dropped: str = "fixed"


@dataclass(frozen=True)
class BaselineConfig:
    """LineBO (``line_budget``, ``directions``, ``line_points``) and unconstrained BO (``unconstrained_refit``,
    EI margin ``xi``)."""

    line_budget: int = 10
    directions: str = "random"
    line_points: int = 300
    unconstrained_refit: int = 1
    xi: float = 0.0


def part(source: Any, cls: type[T]) -> T:
    """The ``cls`` part of a composed config (fields of the same name)."""
    return cls(**{f.name: getattr(source, f.name) for f in fields(cls)})
