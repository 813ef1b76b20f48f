"""The driver loop of the safe GP methods: propose → fly → observe, with the abort budget and the re-fly phase.

* Each trial goes through ``Problem.evaluate_full``, so its outcome (complete / aborted / crashed) reaches the
  state machine: aborted and crashed trials are censored (opt.safe_bo).
* ``max_aborts`` is a hard cap: once that many trials of the run aborted or crashed, the run ends (no further
  trial could be guaranteed not to abort); the recommendation is made from the data.
* Re-fly phase (``refly_last`` > 0): the last evaluations re-fly the ``refly_top`` best completed points (by the
  recommendation's criterion) in turn; the recommendation is then the candidate with the best mean over all its
  flights, an aborted flight counting with its recorded value (below p_min). Bistable gains that flew well once
  rarely survive this.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ksbo_mav.opt.problem import Problem
from ksbo_mav.opt.safe_bo import EXPLOIT_SHARE, Proposal, SafeBO


def refly_count(bo: SafeBO) -> int:
    """Evaluations of the re-fly phase (at most a fifth of the budget)."""
    n = bo.adaptive.refly_last
    return min(n, bo.budget // EXPLOIT_SHARE) if bo.budget > 0 else n


def refly_candidates(bo: SafeBO) -> np.ndarray:
    """(k,) data indices of the ``refly_top`` best distinct completed safe points by the recommendation's
    criterion (the smoothed posterior mean or LCB)."""
    mu, lcb = bo.smoothed()
    crit = lcb if bo.config.recommend == "lcb" else mu
    ok = bo.complete & (bo.y >= bo.p_min)
    if not ok.any():
        ok = bo.complete
    order = [int(i) for i in np.argsort(-np.where(ok, crit, -np.inf)) if ok[i]]
    chosen: list[int] = []
    for i in order:
        if not any(np.array_equal(bo.X[i], bo.X[j]) for j in chosen):
            chosen.append(i)
        if len(chosen) == bo.adaptive.refly_top:
            break
    return np.asarray(chosen, dtype=int)


def refly_choice(bo: SafeBO, cands: np.ndarray) -> int:
    """Data index of the candidate with the best mean over every flight at exactly that point."""
    means = [float(np.mean(bo.y[np.all(bo.X == bo.X[i], axis=1)])) for i in cands]
    return int(cands[int(np.argmax(means))])


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
    cap = bo.adaptive.max_aborts
    while problem.remaining > 0 and (max_iters is None or bo.iteration < max_iters):
        if cap is not None and bo.aborts >= cap:
            problem.stop()
            break
        bo.remaining = problem.remaining - n_refly
        if problem.remaining <= n_refly:
            if bo.refly_set is None:
                bo.refly_set = refly_candidates(bo)
            k = n_refly - problem.remaining
            i = int(bo.refly_set[k % len(bo.refly_set)])
            p = Proposal(bo.X[i].copy(), "refly", float("nan"), float("nan"), float("nan"))
        else:
            p = bo.propose()
        ev, y = problem.evaluate_full(p.x)
        bo.observe(p.x, y, ev.outcome)
        log.append({"kind": p.kind, "mu": p.mu, "sd": p.sd, "lcb": p.lcb, "y": y, "outcome": ev.outcome.value})
        if after is not None:
            after(bo)
    return log


def recommend(bo: SafeBO) -> tuple[int, float, float]:
    """The recommendation: among the re-flown candidates if a re-fly phase ran, else ``bo.recommend()``."""
    i, mu, lcb = bo.recommend()
    cands = bo.refly_set
    if cands is None or len(cands) == 0:
        return i, mu, lcb
    j = refly_choice(bo, cands)
    m, l_ = bo.smoothed()
    return j, float(m[j]), float(l_[j])
