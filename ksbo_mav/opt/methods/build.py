"""Assembling a :class:`~ksbo_mav.opt.safe_bo.SafeBO` from the typed configs (opt.config): which setting goes to
which part."""

from __future__ import annotations

import numpy as np

from ksbo_mav.opt.certificate import Certificate
from ksbo_mav.opt.config import AdaptiveConfig, SafeBOConfig
from ksbo_mav.opt.exclusion import Exclusion
from ksbo_mav.opt.model import SafetyModel
from ksbo_mav.opt.observations import Observations
from ksbo_mav.opt.phases import RULES, Phases
from ksbo_mav.opt.recommend import Recommender
from ksbo_mav.opt.refly import ReflyPhase
from ksbo_mav.opt.region import SearchRegion
from ksbo_mav.opt.safe_bo import Refinement, SafeBO
from ksbo_mav.opt.scale import SafetyScale
from ksbo_mav.opt.surrogate import Surrogate
from ksbo_mav.opt.trust_region import TrustRegion


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
