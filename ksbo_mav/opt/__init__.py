"""Safe Bayesian optimisers (``ksbo`` and the paper's baselines) behind one interface.

Use :func:`ksbo_mav.optimize`; this package holds the methods. ``METHODS`` lists the names. A caller that has
resolved its options once (:func:`options_for`) and built its :class:`Problem` runs a method with
:func:`run_problem`.

The package's top holds the shared vocabulary: the options and their constraints (``options``, ``constraints``,
``config``), the problem and its trials (``problem``, ``observations``, ``outcome``) and the result (``result``).
The parts are grouped by role as BoTorch groups them: ``models/`` (what is fitted to the trials),
``acquisition/`` (where to look and what to ask next) and ``methods/`` (the loops that spend the budget).
"""

from __future__ import annotations

from ksbo_mav.errors import InputError, UnsafeStartError
from ksbo_mav.opt.options import Options, options_for
from ksbo_mav.opt.evaluation import Evaluation, Outcome
from ksbo_mav.opt.problem import Problem, build_result
from ksbo_mav.opt.result import OptimizeResult

METHODS: tuple[str, ...] = ("ksbo", "ksbo-adaptive", "standard", "safeopt", "linebo", "ucb", "ei", "random")

#: Methods that never query a point their GP does not certify safe (apart from fallbacks to safe observations).
SAFE_METHODS: tuple[str, ...] = ("ksbo", "ksbo-adaptive", "standard", "safeopt", "linebo")

#: The safe GP methods (opt.methods.safe_methods): their search box grows towards ``optimize(limits=...)``.
SAFE_GP_METHODS: tuple[str, ...] = ("ksbo", "ksbo-adaptive", "standard", "safeopt")


def run_method(method: str, problem: Problem, opts: Options, seed: int | None) -> OptimizeResult:
    """Spend ``problem``'s remaining budget with ``method`` and return its result (x0 already evaluated)."""
    if method in SAFE_GP_METHODS:
        from ksbo_mav.opt.methods.safe_methods import run_safe_method

        return run_safe_method(problem, method, opts, seed)
    if method == "linebo":
        from ksbo_mav.opt.methods.linebo import run_linebo

        return run_linebo(problem, opts, seed)
    if method in ("ucb", "ei"):
        from ksbo_mav.opt.methods.unconstrained import run_unconstrained

        return run_unconstrained(problem, method, opts, seed)
    if method == "random":
        from ksbo_mav.opt.methods.unconstrained import run_random

        return run_random(problem, opts, seed)
    raise ValueError(f"unknown method {method!r}")


def run_problem(problem: Problem, method: str, opts: Options, seed: int | None = None, *,
                check_x0: bool = True) -> OptimizeResult:
    """The whole run of ``method`` on ``problem`` with options resolved once (``opts``, from :func:`options_for`):
    ``problem.x0`` is evaluated first (counted in the budget), then :func:`run_method` spends the rest.

    Raises:
        InputError: unknown ``method``.
        UnsafeStartError: with ``check_x0``, x0 scored below ``p_min`` or its trial aborted or crashed.
    """
    if method not in METHODS:
        raise InputError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    p_min = problem.p_min
    ev0, y0 = problem.evaluate_full(problem.x0)
    if check_x0 and (ev0.censored or y0 < p_min):
        what = f"fun(x0) = {y0:.6g} < p_min = {p_min:.6g}" if not ev0.censored else f"the trial {ev0.outcome.value}"
        raise UnsafeStartError(f"x0 is unsafe: {what}", None if ev0.value is None else ev0.value, float(p_min))
    if problem.remaining == 0:
        X, _ = problem.data()
        return build_result(problem, method, len(X) - 1, info={"options": opts})
    return run_method(method, problem, opts, seed)


__all__ = ["Evaluation", "Outcome", "METHODS", "SAFE_METHODS", "SAFE_GP_METHODS", "OptimizeResult", "Options",
           "Problem", "options_for", "run_method", "run_problem"]
