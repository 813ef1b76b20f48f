"""Which acquisition rule an iteration of :class:`ksbo_mav.opt.safe_bo.SafeBO` uses: the run's phases.

* Exploitation — the last :func:`n_exploit` evaluations (at most a fifth of the budget) maximise the posterior mean
  (``μ − exploit_beta·σ``) inside the safe set.
* Before that, under ``rule="ucb"``: boundary expansion for the first ``expansion_iters`` BO iterations (at most a
  tenth of the budget), then the safe UCB; under ``rule="safeopt"``: SafeOpt's rule (widest interval among the
  plausible maximisers and boundary points), or the widest feasible interval once an observation's LCB beats every
  candidate's UCB.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt.acquisition import (Acquisition, BoundaryExpansion, PosteriorMean, SafeOptRule, SafeUCB,
                                      WidestFeasible)
from ksbo_mav.opt.recommend import EXPLOIT_SHARE, PHASE_SHARE

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import SafeBO


def n_exploit(bo: "SafeBO") -> int:
    """Evaluations of the final exploitation phase (at most a fifth of the budget)."""
    c = bo.config
    return min(c.exploit_last, bo.budget // EXPLOIT_SHARE) if bo.budget > 0 else c.exploit_last


def exploring(bo: "SafeBO") -> bool:
    """Is the run before its exploitation phase (or of unknown length)?"""
    return bo.remaining is None or bo.remaining > n_exploit(bo)


def choose_rule(bo: "SafeBO", C: np.ndarray, lcb_d: np.ndarray) -> Acquisition:
    """The acquisition rule of this iteration for the candidate set C (m, d); ``lcb_d`` (n,): LCB at the data."""
    c = bo.config
    if not exploring(bo):
        return PosteriorMean(bo, c.exploit_beta)
    if c.rule == "ucb":
        n_expand = min(c.expansion_iters, bo.budget // PHASE_SHARE) if bo.budget > 0 else c.expansion_iters
        if bo.iteration >= n_expand:
            if c.ucb_margin > 0:
                wide = SafeUCB(bo, margin=c.ucb_margin)
                if wide(C)[1].any():
                    return wide
            return SafeUCB(bo)
        return BoundaryExpansion(bo, bo.p_min, c.boundary_tol * bo.model.signal_std)
    _, _, lcb, _ = bo.bounds(C)
    safe = bo.feasible(C, lcb)
    best_lcb = max(float(lcb[safe].max()),
                   float(np.max(np.where((lcb_d >= bo.p_min) & bo.complete, lcb_d, -np.inf))))
    rule = SafeOptRule(bo, bo.p_min, c.boundary_tol * bo.model.signal_std, best_lcb)
    return rule if rule(C)[1].any() else WidestFeasible(bo)  # an observation's LCB beats every UCB
