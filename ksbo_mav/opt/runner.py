"""The driver loop of the safe GP methods: propose → fly → observe, with the abort budget and the re-fly phase.

* Each trial goes through ``Problem.evaluate_full``, so its outcome (complete / aborted / crashed) reaches the
  state machine (with ``censor_aborts`` aborted and crashed trials are censored: opt.safe_bo).
* ``max_aborts`` is a hard cap: once that many trials of the run aborted or crashed, the run ends (no further
  trial could be guaranteed not to abort); the recommendation is made from the data.
* Re-fly phase (``refly_last`` > 0): the last evaluations re-fly the ``refly_top`` best completed points (by the
  recommendation's criterion) in turn; the recommendation is then the candidate with the best mean over all its
  flights (once any trial failed: by expected score under the failure model, opt.recommend). A candidate that
  fails is not re-flown again. Bistable gains that flew well once rarely survive this. With ``refly_stress`` (and
  an objective with ``fun.stress``) each candidate first flies once from the hardest start, and only those that
  pass are re-flown and can be recommended (opt.stress; proposals of kind "stress").
* ``stress_trials``: every trial of the search flies from that hardest start as well (the re-fly phase's
  re-flights keep the objective's own starts).
"""

from __future__ import annotations

from typing import Callable

from ksbo_mav.opt.problem import Problem
from ksbo_mav.opt.outcome import Outcome
from ksbo_mav.opt.recommend import next_refly, refly_candidates, refly_count
from ksbo_mav.opt.safe_bo import Proposal, SafeBO
from ksbo_mav.opt.stress import next_flight, record_stress, screen_order


def run_safe_bo(problem: Problem, bo: SafeBO, max_iters: int | None = None,
                after: Callable[[SafeBO], None] | None = None) -> list[dict]:
    """Spend the remaining budget of ``problem`` with ``bo`` (already fitted on ``problem.data()``).

    With ``max_iters`` stop once ``bo.iteration`` reaches it (e.g. to re-select the kernel); ``after(bo)`` runs
    after every observation (e.g. evidence re-selection).

    Returns one record per query (kind, posterior mean/std/LCB at proposal time, observed y, outcome): the data
    for checking the model's calibration (how often was a certified point unsafe?).
    """
    log: list[dict] = []
    n_refly = refly_count(bo)
    stress = bo.adaptive.refly_stress and problem.can_stress
    stress_trials = bo.adaptive.stress_trials and problem.can_stress  # every search trial from the hard start
    cap = bo.adaptive.max_aborts
    while problem.remaining > 0 and (max_iters is None or bo.iteration < max_iters):
        if cap is not None and bo.aborts >= cap:
            problem.stop()
            break
        bo.remaining = problem.remaining - n_refly
        if problem.remaining <= n_refly:
            if bo.refly_set is None:
                bo.refly_set = screen_order(bo, refly_candidates(bo)) if stress else refly_candidates(bo)
            k = n_refly - problem.remaining
            i, screen = next_flight(bo, k) if stress else (next_refly(bo, k), False)
            p = Proposal(bo.X[i].copy(), "stress" if screen else "refly", float("nan"), float("nan"), float("nan"))
            hard = screen  # the screen's flights from the hardest start, re-flights from the objective's own
        else:
            p, screen, hard = bo.propose(), False, stress_trials
        ev, y = problem.evaluate_full(p.x, stress=hard)
        if screen:
            record_stress(bo, i, ev.outcome is Outcome.COMPLETE and y >= bo.p_min)
        bo.observe(p.x, y, ev.outcome)
        log.append({"kind": p.kind, "mu": p.mu, "sd": p.sd, "lcb": p.lcb, "y": y, "outcome": ev.outcome.value})
        if after is not None:
            after(bo)
    return log
