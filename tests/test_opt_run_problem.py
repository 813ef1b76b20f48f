"""ksbo_mav.opt.run_problem: a run on options resolved once is the run ksbo_mav.optimize makes from keywords."""

from __future__ import annotations

import numpy as np
import pytest

import ksbo_mav
from ksbo_mav.errors import InputError, UnsafeStartError
from ksbo_mav.opt import Problem, options_for, run_problem

LOWER, UPPER = np.array([0.0, -1.0]), np.array([2.0, 1.0])
X0 = np.array([0.6, 0.1])
OPTIONS = {"n_local": 128, "n_global": 32}


def bowl(x: np.ndarray) -> float:
    return float(1.0 - ((x[0] - 1.0) ** 2 + x[1] ** 2) / 0.5)


def _problem(fun, budget: int) -> Problem:
    return Problem(fun=fun, lower=LOWER, upper=UPPER, x0=(X0 - LOWER) / (UPPER - LOWER), budget=budget)


@pytest.mark.parametrize("method", ["ksbo", "random"])
def test_run_problem_is_the_run_optimize_makes(method: str) -> None:
    ref = ksbo_mav.optimize(bowl, X0, np.c_[LOWER, UPPER], budget=6, method=method, seed=2, **OPTIONS)
    got = run_problem(_problem(bowl, 6), method, options_for(method, OPTIONS), seed=2)
    np.testing.assert_array_equal(got.X, ref.X)
    np.testing.assert_array_equal(got.x, ref.x)
    assert got.method == method and got.nfev == 6


def test_run_problem_refuses_an_unsafe_start_and_an_unknown_method() -> None:
    with pytest.raises(UnsafeStartError, match="x0 is unsafe"):
        run_problem(_problem(lambda x: -0.5, 4), "ksbo", options_for("ksbo"))
    with pytest.raises(InputError, match="unknown method"):
        run_problem(_problem(bowl, 4), "nope", options_for("ksbo"))
    one = run_problem(_problem(bowl, 1), "ksbo", options_for("ksbo"))
    assert one.nfev == 1 and one.x == pytest.approx(X0)
