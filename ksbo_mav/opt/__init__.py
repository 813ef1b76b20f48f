"""Safe Bayesian optimisers (``ksbo`` and the paper's baselines) behind one interface.

Use :func:`ksbo_mav.optimize`; this package holds the methods. ``METHODS`` lists the names.
"""

from __future__ import annotations

from ksbo_mav.opt.options import Options, options_for
from ksbo_mav.opt.outcome import Evaluation, Outcome
from ksbo_mav.opt.problem import Problem
from ksbo_mav.opt.result import OptimizeResult

METHODS: tuple[str, ...] = ("ksbo", "ksbo-adaptive", "standard", "safeopt", "linebo", "ucb", "ei", "random")

#: Methods that never query a point their GP does not certify safe (apart from fallbacks to safe observations).
SAFE_METHODS: tuple[str, ...] = ("ksbo", "ksbo-adaptive", "standard", "safeopt", "linebo")


def run_method(method: str, problem: Problem, opts: Options, seed: int | None) -> OptimizeResult:
    """Spend ``problem``'s remaining budget with ``method`` and return its result (x0 already evaluated)."""
    if method in ("ksbo", "ksbo-adaptive", "standard", "safeopt"):
        from ksbo_mav.opt.safe_methods import run_safe_method

        return run_safe_method(problem, method, opts, seed)
    if method == "linebo":
        from ksbo_mav.opt.linebo import run_linebo

        return run_linebo(problem, opts, seed)
    if method in ("ucb", "ei"):
        from ksbo_mav.opt.unconstrained import run_unconstrained

        return run_unconstrained(problem, method, opts, seed)
    if method == "random":
        from ksbo_mav.opt.unconstrained import run_random

        return run_random(problem, opts, seed)
    raise ValueError(f"unknown method {method!r}")


__all__ = ["Evaluation", "Outcome", "METHODS", "SAFE_METHODS", "OptimizeResult", "Options", "options_for", "run_method"]
