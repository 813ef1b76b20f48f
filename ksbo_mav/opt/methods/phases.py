"""Which acquisition rule an iteration of the safe optimiser uses: the run's phases.

* Exploitation — the last :meth:`Phases.n_exploit` evaluations (at most a fifth of the budget) maximise the
  posterior mean (``μ − exploit_beta·σ``) inside the safe set.
* Before that, under ``rule="ucb"``: boundary expansion for the first ``expansion_iters`` BO iterations (at most a
  tenth of the budget; SafeCtrlBO's rule, counted in BO iterations, not observations), then the safe UCB; under
  ``rule="safeopt"``: SafeOpt's rule (widest interval among the plausible maximisers and boundary points), or the
  widest feasible interval once an observation's LCB beats every candidate's UCB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ksbo_mav.opt.acquisition.rules import (Acquisition, BoundaryExpansion, Posterior, PosteriorMean, SafeOptRule,
                                            SafeUCB, WidestFeasible)

#: The exploitation phase takes at most 1/EXPLOIT_SHARE of the budget; the boundary-expansion and the re-fly
#: phases at most 1/PHASE_SHARE each (a 30-flight vehicle campaign keeps 21 flights for the search).
EXPLOIT_SHARE = 5
PHASE_SHARE = 10
RULES = ("ucb", "safeopt")


@dataclass(frozen=True)
class Phases:
    """The phase plan of a run of ``budget`` evaluations (0 = unknown: no caps)."""

    rule: str = "ucb"
    expansion_iters: int = 10
    exploit_last: int = 20
    exploit_beta: float = 0.0
    boundary_tol: float = 0.1
    budget: int = 0

    def n_exploit(self) -> int:
        """Evaluations of the final exploitation phase (at most a fifth of the budget)."""
        return min(self.exploit_last, self.budget // EXPLOIT_SHARE) if self.budget > 0 else self.exploit_last

    def exploring(self, remaining: int | None) -> bool:
        """Is the run, with ``remaining`` evaluations left for the search (None: unknown), before exploitation?"""
        return remaining is None or remaining > self.n_exploit()

    def choose(self, post: Posterior, iteration: int, remaining: int | None, signal_std: float, p_min: float,
               C: np.ndarray, best_data_lcb: float) -> Acquisition:
        """The rule of BO iteration ``iteration`` over the candidate set C (m, d); ``best_data_lcb``: the best LCB of
        a completed, certified observation (SafeOpt's plausibility threshold)."""
        if not self.exploring(remaining):
            return PosteriorMean(post, self.exploit_beta)
        band = self.boundary_tol * signal_std
        if self.rule == "ucb":
            n_expand = min(self.expansion_iters, self.budget // PHASE_SHARE) if self.budget > 0 else \
                self.expansion_iters
            return SafeUCB(post) if iteration >= n_expand else BoundaryExpansion(post, p_min, band)
        _, _, lcb, _ = post.bounds(C)
        safe = post.feasible(C, lcb)
        rule = SafeOptRule(post, p_min, band, max(float(lcb[safe].max()), best_data_lcb))
        return rule if rule(C)[1].any() else WidestFeasible(post)  # an observation's LCB beats every UCB
