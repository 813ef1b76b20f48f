"""optimize's errors: a dedicated error for an unsafe start, clear errors naming the evaluation."""

from __future__ import annotations

import numpy as np
import pytest

import ksbo_mav
from ksbo_mav.errors import InputError, ObjectiveError, UnsafeStartError
from ksbo_mav.opt.evaluation import Evaluation, Outcome

BOUNDS = np.array([[0.0, 1.0], [0.0, 1.0]])
X0 = np.array([0.5, 0.5])


def test_unsafe_start_has_its_own_error_with_the_value() -> None:
    with pytest.raises(UnsafeStartError, match="x0 is unsafe") as info:
        ksbo_mav.optimize(lambda x: -0.25, X0, BOUNDS, budget=5)
    assert isinstance(info.value, InputError) and info.value.value == -0.25 and info.value.p_min == 0.0
    with pytest.raises(UnsafeStartError, match="aborted"):
        ksbo_mav.optimize(lambda x: Evaluation(None, Outcome.ABORTED), X0, BOUNDS, budget=5)


@pytest.mark.parametrize("bad, match", [
    (float("nan"), "returned nan at evaluation 1"),
    (None, "returned None at evaluation 1"),
    (np.array([0.1, 0.2]), r"array of shape \(2,\) at evaluation 1"),
    ("0.3", "returned str"),
    (Evaluation(None, Outcome.COMPLETE), "without a value at evaluation 1"),
])
def test_bad_return_values_name_the_evaluation(bad: object, match: str) -> None:
    calls = []

    def fun(x: np.ndarray) -> object:
        calls.append(x)
        return 0.5 if len(calls) == 1 else bad

    with pytest.raises(ObjectiveError, match=match) as info:
        ksbo_mav.optimize(fun, X0, BOUNDS, budget=5, method="random", seed=0)
    assert "x = [" in str(info.value)


def test_nan_at_x0_is_not_reported_as_an_unsafe_value() -> None:
    with pytest.raises(ObjectiveError, match="evaluation 0"):
        ksbo_mav.optimize(lambda x: float("nan"), X0, BOUNDS, budget=5)


def test_an_exception_in_fun_propagates_unchanged_with_a_note() -> None:
    class Boom(RuntimeError):
        pass

    def fun(x: np.ndarray) -> float:
        if x[0] != 0.5:
            raise Boom("sensor died")
        return 0.5

    with pytest.raises(Boom, match="sensor died") as info:
        ksbo_mav.optimize(fun, X0, BOUNDS, budget=5, method="random", seed=0)
    assert any("evaluation 1" in n for n in info.value.__notes__)


def test_one_element_arrays_and_numpy_scalars_are_accepted() -> None:
    vals = iter([np.float32(0.5), np.array([0.6]), np.array(0.7)])
    r = ksbo_mav.optimize(lambda x: next(vals), X0, BOUNDS, budget=3, method="random", seed=0)
    np.testing.assert_allclose(r.y, [0.5, 0.6, 0.7], rtol=1e-6)


def test_unchecked_aborted_start_is_refused_by_the_safe_methods() -> None:
    with pytest.raises(UnsafeStartError, match="did not complete"):
        ksbo_mav.optimize(lambda x: Evaluation(None, Outcome.ABORTED), X0, BOUNDS, budget=3, check_x0=False)
