"""The driver loop of the safe GP methods: propose → fly → observe, with the abort budget and the re-fly phase.

* Each trial goes through ``Problem.evaluate_full``, so its outcome (complete / aborted / crashed) reaches the
  state machine (with censoring, aborted and crashed trials never enter the GPs as values: opt.observations).
* ``max_aborts`` is a hard cap: once that many trials of the run aborted or crashed, the run ends (no further
  trial could be guaranteed not to abort); the recommendation is made from the data.
* The stopping rule (opt.methods.stopping), where the options turn it on, ends the search before the budget once
  what the next proposal can gain stays below the objective's noise (a check right after the growing box moved
  never counts); the re-fly phase is then skipped.
* The re-fly phase (opt.methods.refly) takes the last evaluations: the best candidates are re-flown (after a stress
  flight each where the objective has ``fun.stress``), and the recommendation is the one that held up.
"""

from __future__ import annotations

from typing import Callable

from ksbo_mav.opt.methods.safe_bo import Proposal, SafeBO
from ksbo_mav.opt.evaluation import Outcome
from ksbo_mav.opt.problem import Problem


def run_safe_bo(problem: Problem, bo: SafeBO, max_iters: int | None = None,
                after: Callable[[SafeBO], None] | None = None) -> list[dict]:
    """Spend the remaining budget of ``problem`` with ``bo`` (already fitted on ``problem.data()``).

    With ``max_iters`` stop once ``bo.iteration`` reaches it (e.g. to re-select the kernel); ``after(bo)`` runs
    after every observation (e.g. evidence re-selection).

    Returns one record per query (kind, posterior mean/std/LCB at proposal time, observed y, outcome): the data
    for checking the model's calibration (how often was a certified point unsafe?).
    """
    log: list[dict] = []
    refly = bo.refly
    n_refly = refly.count()
    while problem.remaining > 0 and (max_iters is None or bo.iteration < max_iters):
        if bo.max_aborts is not None and bo.obs.aborts >= bo.max_aborts:
            problem.stop()
            break
        bo.remaining = problem.remaining - n_refly
        screen = False
        if problem.remaining <= n_refly:
            if refly.chosen is None:
                refly.start(bo.criterion(), bo.obs, bo.certificate)
            i, screen = refly.next_flight(n_refly - problem.remaining, bo.criterion, bo.obs, bo.certificate)
            nan = float("nan")
            p = Proposal(bo.obs.X[i].copy(), "stress" if screen else "refly", nan, nan, nan)
        else:
            p = bo.propose()
            stop = bo.stopping
            grew = bo.box is not None and any(g.trial == bo.iteration for g in bo.box.history)
            if stop is not None and stop.should_stop(bo, bo.obs, p.x, p.kind, problem.n_evals, bo.model.noise_std,
                                                     box_grew=grew):
                problem.stop()
                break
        # The screen's flights go from the hardest start, the re-flights from the objective's own starts.
        ev, y = problem.evaluate_full(p.x, stress=screen)
        if screen:
            refly.record_stress(i, ev.outcome is Outcome.COMPLETE and y >= bo.p_min)
        bo.observe(p.x, y, ev.outcome)
        log.append({"kind": p.kind, "mu": p.mu, "sd": p.sd, "lcb": p.lcb, "y": y, "outcome": ev.outcome.value})
        if after is not None:
            after(bo)
    return log
