"""Assembling a :class:`~ksbo_mav.opt.methods.safe_bo.SafeBO`: which setting goes to which part.

* :func:`build_safe_bo` — from the typed configs (opt.method_config) and the GPs.
* :func:`safe_bo_for` — from a :class:`~ksbo_mav.opt.problem.Problem` and its :class:`~ksbo_mav.opt.options.Options`
  with the kernel orders chosen: the GPs (:func:`model_spec`), the configs (:func:`bo_config`) and the rest.
"""

from __future__ import annotations

import numpy as np

from ksbo_mav.opt.acquisition.certificate import Certificate
from ksbo_mav.opt.acquisition.exclusion import Exclusion
from ksbo_mav.opt.acquisition.growing_box import GrowingBox
from ksbo_mav.opt.acquisition.region import SearchRegion
from ksbo_mav.opt.acquisition.trust_region import TrustRegion
from ksbo_mav.opt.method_config import AdaptiveConfig, SafeBOConfig, part
from ksbo_mav.opt.methods.phases import RULES, Phases
from ksbo_mav.opt.methods.recommend import Recommender
from ksbo_mav.opt.methods.refly import ReflyPhase
from ksbo_mav.opt.methods.safe_bo import Refinement, SafeBO
from ksbo_mav.opt.methods.stopping import rule_from
from ksbo_mav.opt.models.safety_model import ModelSpec, SafetyModel, active_mask
from ksbo_mav.opt.models.scale import SafetyScale
from ksbo_mav.opt.models.surrogate import Surrogate
from ksbo_mav.opt.observations import Observations
from ksbo_mav.opt.options import Options
from ksbo_mav.opt.problem import Problem


def build_safe_bo(model: SafetyModel, config: SafeBOConfig, free: np.ndarray, rng: np.random.Generator, *,
                  x0: np.ndarray | None = None, safety_model: SafetyModel | None = None, n_prior: int = 0,
                  budget: int = 0, adaptive: AdaptiveConfig | None = None, stress: bool = False) -> SafeBO:
    """A safe optimiser over ``model`` (and ``safety_model``, which must certify every query too).

    Args:
        free: (d,) bool dimensions the optimiser may move (the others stay at ``x0``).
        x0: (d,) start (default: the first data point given to ``fit``).
        n_prior: leading rows of the data that are prior (not evaluated by this run).
        budget: evaluations of the whole run (caps the phases); 0 = unknown, no caps.
        stress: the objective offers a flight from its hardest start (used by the re-fly phase's screen).
    """
    c, a = config, adaptive or AdaptiveConfig()
    if c.rule not in RULES:
        raise ValueError(f"unknown rule {c.rule!r}; expected one of {RULES}")
    tr = TrustRegion(a.tr_init, a.tr_min, a.tr_max, a.tr_grow, a.tr_shrink, a.tr_success) if a.trust_region else None
    scale = SafetyScale(a.learn_safety_scale, a.safety_scale_prior, a.safety_scale_bounds, a.scale_refit_every,
                        a.scale_extent_factor, a.failure_scale_shrink, a.unsafe_scale_shrink, a.ard_acquisition)
    cert = Certificate(c.beta, c.beta_ucb, a.backup_beta, c.cap_mean, c.y_max,
                       Exclusion(c.exclusion_radius, a.exclusion_growth, max(a.exclusion_max, c.exclusion_radius)),
                       track_failures=a.backup_beta is not None or a.censor_aborts, abort_tol=a.abort_tol,
                       crash_tol=a.crash_tol)
    return SafeBO(
        obs=Observations(model.dim, model.p_min, n_prior, a.censor_aborts),
        surrogate=Surrogate(model, safety_model, scale),
        certificate=cert,
        region=SearchRegion(np.asarray(free, dtype=bool), None if x0 is None else np.asarray(x0, dtype=float),
                            c.n_anchors, c.n_local, tuple(c.local_scales), c.n_global, c.explore_from),
        phases=Phases(c.rule, c.expansion_iters, c.exploit_last, c.exploit_beta, c.boundary_tol, budget),
        recommender=Recommender(c.recommend, c.recommend_noise, c.beta),
        refly=ReflyPhase(a.refly_last, a.refly_top, a.refly_stress and stress, budget),
        rng=rng, trust_region=tr,
        refinement=Refinement(c.refine_starts, c.refine_rounds, c.refine_samples, c.refine_scale),
        refit_every=c.refit_every, max_aborts=a.max_aborts,
    )


def bo_config(opts: Options) -> SafeBOConfig:
    """The :class:`SafeBOConfig` part of ``opts``."""
    cfg = part(opts, SafeBOConfig)
    return cfg if isinstance(cfg.local_scales, tuple) else SafeBOConfig(**{**cfg.__dict__,
                                                                          "local_scales": tuple(cfg.local_scales)})


def model_spec(opts: Options, orders: tuple[int, ...], active_dims: tuple[int, ...] | None = None) -> ModelSpec:
    """The :class:`ModelSpec` part of ``opts`` with the given kernel orders."""
    return ModelSpec(
        orders=tuple(int(r) for r in orders),
        lengthscale=opts.lengthscale,
        signal_std=opts.signal_std,
        signal_scale=opts.signal_scale,
        noise_std=opts.noise_std,
        noise_ratio=opts.noise_ratio,
        active_dims=active_dims,
        optimize=opts.optimize_hypers,
        dropped_in_order1=opts.dropped == "order1",
    )


def safe_bo_for(
    problem: Problem, opts: Options, orders: tuple[int, ...], dims: tuple[int, ...] | None, seed: int | None,
    rng: np.random.Generator,
) -> SafeBO:
    """The :class:`SafeBO` that ``ksbo``, ``standard`` and ``safeopt`` run on ``problem``: the main GP with
    additive kernel ``orders`` (those above ``problem.dim``, or above the number of ``dims``, dropped) on the
    active dimensions ``dims`` (None: all), the local SE-ARD safety GP when ``opts.safety_kernel == "se"``, and
    every other part set from ``opts`` (the stopping rule from ``problem.early_stop``, a growing search box where the
    problem has limits past the cube). Not yet fitted: call ``fit`` on
    ``problem.data()``. ``seed`` seeds the
    GPs, ``rng`` the candidates."""
    d = problem.dim
    orders = tuple(r for r in orders if 1 <= r <= d) or (d,)
    spec = model_spec(opts, orders, dims)
    if dims is not None:
        # Orders above the number of active dimensions do not exist on the subspace.
        spec = spec.with_(orders=tuple(r for r in orders if r <= len(dims)) or (len(dims),))
    model = SafetyModel(spec, d, problem.p_min, seed=seed)
    safety = None
    if opts.safety_kernel == "se" and spec.orders != (d,):
        # A local, product-SE GP must certify safety too: additive kernels keep a high correlation when one
        # dimension changes a lot, which on a task with cliffs certifies unsafe gains (see BENCHMARKS.md).
        sspec = model_spec(opts.update({"lengthscale": opts.safety_lengthscale}), (d,), None)
        safety = SafetyModel(sspec, d, problem.p_min, seed=seed)
    elif opts.safety_kernel not in ("same", "se"):
        raise ValueError(f"unknown safety_kernel {opts.safety_kernel!r}")
    bo = build_safe_bo(model, bo_config(opts), active_mask(d, dims, spec.dropped_in_order1), rng, x0=problem.x0,
                       safety_model=safety, n_prior=len(problem.prior_y), budget=problem.budget,
                       adaptive=part(opts, AdaptiveConfig), stress=problem.can_stress)
    if problem.early_stop is not None:
        bo.stopping = rule_from(problem.early_stop)
    if problem.can_grow:
        bo.region.box = GrowingBox(problem.limit_lo, problem.limit_hi)
        if problem.on_grow is not None:
            bo.on_grow = lambda g: problem.on_grow(problem.growth_record(g))
    return bo
