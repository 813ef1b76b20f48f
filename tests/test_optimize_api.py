"""Public API: ksbo_mav.optimize validates its arguments, respects the budget and is reproducible."""

from __future__ import annotations

import numpy as np
import pytest

import ksbo_mav
from ksbo_mav.errors import InputError
from ksbo_mav.opt import METHODS

BOUNDS = np.array([[0.0, 2.0], [-1.0, 1.0]])
X0 = np.array([0.6, 0.1])


def bowl(x: np.ndarray) -> float:
    """Smooth 2-D objective, safe (≥ 0) in a disc around (1, 0), optimum 1 at (1, 0)."""
    return float(1.0 - ((x[0] - 1.0) ** 2 + x[1] ** 2) / 0.5)


FAST = {"n_local": 128, "n_global": 32}


@pytest.mark.parametrize("method", METHODS)
def test_budget_respected_and_reproducible(method: str) -> None:
    calls = []

    def f(x: np.ndarray) -> float:
        calls.append(x.copy())
        return bowl(x)

    r1 = ksbo_mav.optimize(f, X0, BOUNDS, budget=7, method=method, seed=3, **FAST)
    assert len(calls) == 7 and r1.nfev == 7
    assert r1.X.shape == (7, 2) and r1.y.shape == (7,)
    np.testing.assert_allclose(r1.X[0], X0)  # the start is the first evaluation
    np.testing.assert_allclose(r1.y, [bowl(x) for x in r1.X])
    assert r1.n_unsafe == int(np.sum(r1.y < 0))
    assert np.all(r1.X >= BOUNDS[:, 0] - 1e-12) and np.all(r1.X <= BOUNDS[:, 1] + 1e-12)
    assert r1.seconds.shape == (7,)
    r2 = ksbo_mav.optimize(bowl, X0, BOUNDS, budget=7, method=method, seed=3, **FAST)
    np.testing.assert_array_equal(r1.X, r2.X)
    np.testing.assert_array_equal(r1.x, r2.x)
    # The recommendation is one of the evaluated points and `fun` is its observed value.
    assert any(np.allclose(r1.x, x) for x in r1.X)
    assert r1.fun == pytest.approx(bowl(r1.x))


def test_budget_one_returns_x0() -> None:
    r = ksbo_mav.optimize(bowl, X0, BOUNDS, budget=1)
    assert r.nfev == 1
    np.testing.assert_allclose(r.x, X0)


def test_prior_is_used_but_not_counted() -> None:
    rng = np.random.default_rng(0)
    pX = np.column_stack([rng.uniform(0.5, 1.5, 12), rng.uniform(-0.4, 0.4, 12)])
    py = np.array([bowl(x) for x in pX])
    r = ksbo_mav.optimize(bowl, X0, BOUNDS, budget=5, prior=(pX, py), seed=0, orders=(1, 2), **FAST)
    assert r.nfev == 5
    np.testing.assert_allclose(r.prior_X, pX)
    np.testing.assert_allclose(r.prior_y, py)
    # With a good prior the recommendation is at least as good as the best prior point's neighbourhood.
    assert r.fun >= 0.0


def test_callback_sees_every_evaluation_and_can_stop() -> None:
    seen = []

    def cb(i: int, x: np.ndarray, y: float) -> bool:
        seen.append((i, y))
        return i >= 3

    r = ksbo_mav.optimize(bowl, X0, BOUNDS, budget=10, callback=cb, seed=0, **FAST)
    assert [i for i, _ in seen] == [0, 1, 2, 3]
    assert r.nfev == 4


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"x0": [3.0, 0.0]}, "outside bounds"),
        ({"x0": [0.5]}, "shape"),
        ({"x0": [0.5, 0.0, 1.0]}, "shape"),
        ({"x0": [np.nan, 0.0]}, "NaN"),
        ({"bounds": [[0, 1]]}, "shape"),
        ({"bounds": [[0, 1, 2], [0, 1, 2]]}, "shape"),
        ({"bounds": [[1.0, 0.0], [-1, 1]]}, "lower < upper"),
        ({"budget": 0}, "budget"),
        ({"budget": 2.5}, "budget"),
        ({"budget": True}, "budget"),
        ({"method": "cmaes"}, "unknown method"),
        ({"frobnicate": 1}, "unknown option"),
        ({"prior": ([[0.5, 0.0]], [1.0, 2.0])}, "shape"),
        ({"prior": ([[5.0, 0.0]], [1.0])}, "outside bounds"),
        ({"prior": "nope"}, "pair"),
        ({"fun": 3}, "callable"),
    ],
)
def test_bad_arguments_raise_input_error(kwargs: dict, match: str) -> None:
    args = {"fun": bowl, "x0": X0, "bounds": BOUNDS, "budget": 5}
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        ksbo_mav.optimize(args.pop("fun"), args.pop("x0"), args.pop("bounds"), **args)


def test_unsafe_x0_rejected_when_checked() -> None:
    x_bad = np.array([1.9, 0.9])
    assert bowl(x_bad) < 0
    with pytest.raises(InputError, match="x0 is unsafe"):
        ksbo_mav.optimize(bowl, x_bad, BOUNDS, budget=5)
    r = ksbo_mav.optimize(bowl, x_bad, BOUNDS, budget=2, check_x0=False, method="random", seed=0)
    assert r.nfev == 2


def test_input_error_is_a_value_error() -> None:
    with pytest.raises(ValueError):
        ksbo_mav.optimize(bowl, X0, BOUNDS, budget=-1)
