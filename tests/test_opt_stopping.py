"""The stopping rule of the safe optimiser (opt.methods.stopping) on synthetic objectives: it stops on a flat
objective, not while evaluations still pay, never before its minimum and never past the budget."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_mav import optimize
from ksbo_mav.opt.methods.stopping import StopCheck, StoppingRule

BOUNDS = np.array([[0.0, 1.0], [0.0, 1.0]])
X0 = np.array([0.1, 0.1])


def flat(x: np.ndarray) -> float:
    return 0.5 + 1e-4 * float(np.sin(x.sum()))


def steep(x: np.ndarray) -> float:
    """Rises by 0.9 across the box: every step the trust region allows gains far more than the noise."""
    return float(min(0.1 + 0.9 * x[0] + 0.3 * x[1], 1.0))


def _prior(f) -> tuple[np.ndarray, np.ndarray]:
    X = np.clip(X0 + 0.15 * np.random.default_rng(0).standard_normal((12, 2)), 0.0, 1.0)
    return X, np.array([f(x) for x in X])


def _run(f, budget: int, **stop) -> object:
    return optimize(f, X0, BOUNDS, budget=budget, method="ksbo-adaptive", seed=0, prior=_prior(f), signal_std=1.0,
                    y_max=1.0, early_stop=stop)


def test_stops_on_a_flat_objective_at_its_minimum():
    r = _run(flat, 30, min_evals=4)
    stop = r.info["stop"]
    assert stop["stopped"] and len(r.y) == 4 and stop["after"] == 4 and stop["saved"] == 26
    last = stop["checks"][-1]
    assert last["gain"] < last["threshold"] == pytest.approx(last["noise"])  # the model's noise std, ratio 1


def test_respects_the_minimum():
    r = _run(flat, 30, min_evals=7)
    stop = r.info["stop"]
    assert len(r.y) == 7 and stop["stopped"]
    assert all(c["gain"] < c["threshold"] for c in stop["checks"][1:])  # below from check 2: the minimum held it


def test_does_not_stop_while_evaluations_pay():
    r = _run(steep, 30, min_evals=2, noise=0.005)
    stop, y = r.info["stop"], np.asarray(r.y)
    assert stop["stopped"] and len(y) > 2  # past its minimum: the flights after it were still paying
    # Every check before the stop saw the last evaluation raise the best flown value by more than the noise...
    for c in stop["checks"][1:-1]:
        n = c["after"]
        assert y[:n].max() - y[: n - 1].max() > 0.005
    # ...and the stop came after one that did not.
    n = stop["after"]
    assert y[:n].max() - y[: n - 1].max() < 0.005


def test_the_budget_stays_the_ceiling():
    r = _run(steep, 6, min_evals=2, noise=0.005)
    assert len(r.y) == 6 and not r.info["stop"]["stopped"] and r.info["stop"]["saved"] == 0
    r = _run(flat, 3, min_evals=4)
    assert len(r.y) == 3 and not r.info["stop"]["stopped"]


def test_off_by_default_spends_the_budget():
    r = optimize(flat, X0, BOUNDS, budget=8, method="ksbo-adaptive", seed=0, prior=_prior(flat), signal_std=1.0,
                 y_max=1.0)
    assert len(r.y) == 8 and "stop" not in r.info


def test_a_bad_rule_table_is_one_line_naming_it():
    from ksbo_mav.errors import InputError

    for bad, name in (({"patience": 0}, "patience"), ({"min_evals": 2.5}, "min_evals"), ({"ratio": -1}, "ratio"),
                      ({"noise": 0}, "noise"), ({"when": 3}, "unknown key")):
        with pytest.raises(InputError, match=rf"^early_stop: {name}") as err:
            _run(flat, 5, **bad)
        assert "\n" not in str(err.value)


def test_a_fallback_never_counts_towards_stopping():
    rule = StoppingRule(patience=1, min_evals=1)
    assert not StopCheck(3, "fallback", 0.0, 0.02, 0.02).below
    assert StopCheck(3, "ucb", 0.0, 0.02, 0.02).below
    rule.checks.append(StopCheck(1, "ucb", 0.0, 0.02, 0.02))
    assert rule.summary(10)["checks"][0]["kind"] == "ucb"


def test_the_check_after_the_search_box_grew_never_counts_towards_stopping():
    assert not StopCheck(3, "ucb", 0.0, 0.02, 0.02, box_grew=True).below

    def rising(x: np.ndarray) -> float:  # better past the first box's upper edge in x[0], where it starts
        return float(min(0.3 + 0.2 * x[0] - 0.1 * (x[1] - 0.5) ** 2, 1.0))

    x0 = np.array([0.97, 0.5])
    X = np.clip(x0 + 0.05 * np.random.default_rng(0).standard_normal((12, 2)), 0.0, 1.0)
    r = optimize(rising, x0, BOUNDS, budget=30, method="ksbo-adaptive", seed=0, prior=(X, [rising(x) for x in X]),
                 signal_std=1.0, y_max=1.0, early_stop={"min_evals": 2, "noise": 0.01},
                 limits=np.array([[0.0, 3.0], [0.0, 1.0]]))
    checks, growth = r.info["stop"]["checks"], r.info["box"]["growth"]
    assert [g["dim"] for g in growth] == [0]  # the box grew along x[0] ...
    grew = [c for c in checks if c["box_grew"]]
    assert len(grew) == 1 and grew[0]["gain"] < grew[0]["threshold"]  # ... and the check after it was below ...
    assert len(r.y) > grew[0]["after"] >= 2  # ... past the minimum, yet the search went on into the new room
    assert r.X[-1][0] > 1.0
